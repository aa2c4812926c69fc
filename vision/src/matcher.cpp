#include "rgbdmap/vision/matcher.hpp"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstring>

namespace rgbdmap {
namespace {

struct Nearest {
  int best = INT_MAX, second = INT_MAX, index = -1;
};

inline int hamming256(const uint64_t* a, const uint64_t* b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}

// Exhaustive search over 256-bit descriptors. Cloned for CPUs with POPCNT (no -march flags needed):
// the loader picks the fastest variant at start-up.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("popcnt", "default")))
#endif
void nearestTwo(const uint64_t* query, const uint64_t* train, int n_query, int n_train, const char* mask,
                Nearest* out) {
  for (int q = 0; q < n_query; ++q) {
    const uint64_t* a = query + 4 * q;
    Nearest n;
    for (int t = 0; t < n_train; ++t) {
      if (mask && !mask[t]) continue;
      const int d = hamming256(a, train + 4 * t);
      if (d < n.best) {
        n.second = n.best;
        n.best = d;
        n.index = t;
      } else if (d < n.second) {
        n.second = d;
      }
    }
    out[q] = n;
  }
}

// Copies descriptor rows into a 64-bit aligned buffer (cv::Mat rows are 32 bytes but may be unaligned).
std::vector<uint64_t> packDescriptors(const cv::Mat& d) {
  std::vector<uint64_t> out(static_cast<size_t>(d.rows) * 4);
  for (int r = 0; r < d.rows; ++r) std::memcpy(&out[4 * r], d.ptr<uint8_t>(r), 32);
  return out;
}

}  // namespace

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("popcnt", "default")))
#endif
int hammingDistance(const uint8_t* a, const uint8_t* b) {
  uint64_t x[4], y[4];
  std::memcpy(x, a, 32);
  std::memcpy(y, b, 32);
  return hamming256(x, y);
}

std::vector<FeatureMatch> matchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                           const MatcherConfig& config, const std::vector<char>* train_mask) {
  std::vector<FeatureMatch> matches;
  if (query.empty() || train.empty()) return matches;
  CV_Assert(query.type() == CV_8U && train.type() == CV_8U && query.cols == 32 && train.cols == 32);
  const std::vector<uint64_t> q = packDescriptors(query), t = packDescriptors(train);
  std::vector<Nearest> nearest(query.rows);
  nearestTwo(q.data(), t.data(), query.rows, train.rows, train_mask ? train_mask->data() : nullptr,
             nearest.data());

  int min_distance = INT_MAX;
  for (const auto& n : nearest)
    if (n.index >= 0) min_distance = std::min(min_distance, n.best);
  if (min_distance == INT_MAX) return matches;
  const double limit = std::min<double>(
      config.max_distance, std::max<double>(config.k_min_distance * min_distance, config.min_distance_floor));
  // One-to-one: the best query per train index wins.
  std::vector<int> owner(train.rows, -1);
  for (int i = 0; i < query.rows; ++i) {
    const Nearest& n = nearest[i];
    if (n.index < 0 || n.best > limit) continue;
    if (n.second != INT_MAX && n.best > config.ratio * n.second) continue;
    int& o = owner[n.index];
    if (o < 0 || nearest[o].best > n.best) o = i;
  }
  for (int t_idx = 0; t_idx < train.rows; ++t_idx)
    if (owner[t_idx] >= 0) matches.push_back({owner[t_idx], t_idx, nearest[owner[t_idx]].best});
  return matches;
}

}  // namespace rgbdmap
