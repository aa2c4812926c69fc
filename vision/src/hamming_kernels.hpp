#pragma once
// Hamming distances over 256-bit ORB descriptors, packed as four 64-bit words. The search over many train
// descriptors runs on columns (word w of every train descriptor contiguous): the distances, the mask and
// the two minima are plain loops the compiler vectorises (with vector popcounts on CPUs that have AVX-512
// VPOPCNTDQ). The variant is chosen once at start-up; the results are the same on every CPU.
#include <climits>
#include <cstdint>
#include <cstring>
#include <vector>

#include <opencv2/core.hpp>

namespace rgbdmap::vision_detail {

inline int hamming256(const uint64_t* a, const uint64_t* b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}

/// Descriptor rows copied into 64-bit words, row r at [4r, 4r+4) (cv::Mat rows may be unaligned).
inline std::vector<uint64_t> packRows(const cv::Mat& d) {
  std::vector<uint64_t> out(static_cast<size_t>(d.rows) * 4);
  for (int r = 0; r < d.rows; ++r) std::memcpy(&out[4 * static_cast<size_t>(r)], d.ptr<uint8_t>(r), 32);
  return out;
}

/// Descriptor rows as four columns: word w of row r at [w * rows + r].
inline std::vector<uint64_t> packColumns(const cv::Mat& d) {
  const size_t n = static_cast<size_t>(d.rows);
  std::vector<uint64_t> out(4 * n);
  for (size_t r = 0; r < n; ++r) {
    uint64_t w[4];
    std::memcpy(w, d.ptr<uint8_t>(static_cast<int>(r)), 32);
    for (size_t k = 0; k < 4; ++k) out[k * n + r] = w[k];
  }
  return out;
}

/// The closest and second-closest distance, and the index of the closest (the lowest index on ties).
struct NearestTwo {
  int best = INT_MAX, second = INT_MAX, index = -1;
  /// Takes row `row` at distance `d` into account; rows offered in ascending order keep the lowest on ties.
  void offer(int d, int row) {
    if (d < best) {
      second = best;
      best = d;
      index = row;
    } else if (d < second) {
      second = d;
    }
  }
};

/// The nearest two train rows of `columns` (packColumns of n rows) to `query` (4 words), among the rows
/// with mask[t] != 0 (all rows without a mask). `scratch` holds at least n values.
NearestTwo nearestTwoOf(const uint64_t* query, const uint64_t* columns, int n, const char* mask,
                        uint32_t* scratch);

}  // namespace rgbdmap::vision_detail
