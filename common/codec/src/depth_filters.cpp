#include "depth_filters.hpp"

#include <algorithm>
#include <string>

#include "image_blob.hpp"

namespace rgbdmap::detail {
namespace {

// kRankMed. Ranks index the table of distinct non-zero depths; a Kinect frame has a few hundred, so
// neighbouring ranks differ by a few units where the raw depths differ by tens. With a = left, b = above,
// c = above-left and `last` = the rank of the previous pixel with depth in scan order (0 at first):
//   a, b, c all with depth:        LOCO-I median (MED) = median(a, b, a + b - c)
//   a a hole (or outside), b not:  b
//   otherwise:                     last (which is a whenever a has depth)
// The decoder carries only `last` from pixel to pixel; the hole flags and b - c are known beforehand,
// which keeps the loop-carried dependency short.
inline int predictRank(bool a_hole, int b, int c, int last) {
  if (a_hole) return b != kHole ? b : last;
  if (b == kHole || c == kHole) return last;
  return std::max(std::min(last, b), std::min(std::max(last, b), last + b - c));
}

inline uint16_t zigzag(int r) { return static_cast<uint16_t>(r >= 0 ? 2 * r : -2 * r - 1); }
inline int unzigzag(int z) { return (z & 1) ? -((z + 1) >> 1) : (z >> 1); }

}  // namespace

// ---- kNone
// -------------------------------------------------------------------------------------------------
void packRaw(const cv::Mat& depth, Bytes& out) {
  out.resize(2 * depth.total());
  uint8_t* p = out.data();
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* row = depth.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x, p += 2) putU16(p, row[x]);
  }
}

void unpackRaw(const uint8_t* in, cv::Mat& depth) {
  for (int y = 0; y < depth.rows; ++y) {
    uint16_t* row = depth.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x, in += 2) row[x] = getU16(in);
  }
}

// ---- kRowDelta: left of column 0 is the pixel above; above row 0 it is 0
// --------------------------------------
void packRowDelta(const cv::Mat& depth, Bytes& out) {
  const size_t n = depth.total();
  out.resize(2 * n);
  uint8_t* hi = out.data();
  uint8_t* lo = hi + n;
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* row = depth.ptr<uint16_t>(y);
    uint16_t left = y > 0 ? depth.ptr<uint16_t>(y - 1)[0] : 0;
    for (int x = 0; x < depth.cols; ++x) {
      const uint16_t code = zigzag16(static_cast<uint16_t>(row[x] - left));
      *hi++ = static_cast<uint8_t>(code >> 8);
      *lo++ = static_cast<uint8_t>(code & 0xFF);
      left = row[x];
    }
  }
}

void unpackRowDelta(const uint8_t* in, cv::Mat& depth) {
  const uint8_t* hi = in;
  const uint8_t* lo = in + depth.total();
  for (int y = 0; y < depth.rows; ++y) {
    uint16_t* row = depth.ptr<uint16_t>(y);
    uint16_t left = y > 0 ? depth.ptr<uint16_t>(y - 1)[0] : 0;
    for (int x = 0; x < depth.cols; ++x) {
      left = static_cast<uint16_t>(left + unzigzag16(static_cast<uint16_t>((*hi++ << 8) | *lo++)));
      row[x] = left;
    }
  }
}

// ---- kRankMed
// ----------------------------------------------------------------------------------------------
std::vector<uint16_t> distinctNonZero(const cv::Mat& depth) {
  std::vector<uint8_t> seen(65536, 0);
  for (int y = 0; y < depth.rows; ++y) {
    const uint16_t* row = depth.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x) seen[row[x]] = 1;
  }
  std::vector<uint16_t> table;
  for (int v = 1; v < 65536; ++v)
    if (seen[v]) table.push_back(static_cast<uint16_t>(v));
  return table;
}

void packRankMed(const cv::Mat& depth, const std::vector<uint16_t>& table, Bytes& out) {
  const size_t k = table.size(), n = depth.total();
  out.resize(2 * k + 2 * n);
  std::vector<int> rank_of(65536, kHole);
  for (size_t t = 0; t < k; ++t) {
    rank_of[table[t]] = static_cast<int>(t);
    putU16(&out[2 * t], static_cast<uint16_t>(table[t] - (t ? table[t - 1] : 0)));
  }
  uint8_t* hi = out.data() + 2 * k;
  uint8_t* lo = hi + n;
  std::vector<int> prev(depth.cols + 1, kHole), cur(depth.cols + 1, kHole);  // [0] is left of column 0
  int last = 0;
  for (int y = 0; y < depth.rows; ++y, std::swap(prev, cur)) {
    const uint16_t* row = depth.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x) {
      const int rank = rank_of[row[x]];  // rank_of[0] is kHole
      const int p = predictRank(cur[x] == kHole, prev[x + 1], prev[x], last);
      const uint16_t symbol = rank != kHole ? static_cast<uint16_t>(1 + zigzag(rank - p)) : 0;
      *hi++ = static_cast<uint8_t>(symbol >> 8);
      *lo++ = static_cast<uint8_t>(symbol & 0xFF);
      last = rank != kHole ? rank : last;
      cur[x + 1] = rank;
    }
  }
}

namespace {

/// value_of[0] = 0 is the hole; value_of[1 + rank] is the depth of `rank`.
Status unpackRankTable(const uint8_t* in, size_t table_size, std::vector<uint16_t>& value_of) {
  value_of.assign(table_size + 1, 0);
  for (size_t t = 0; t < table_size; ++t) {
    const int next = value_of[t] + getU16(in + 2 * t);
    if (next <= value_of[t] || next > 65535)
      return Status::failure("depth blob: rank table entry " + std::to_string(t) +
                             " is not strictly ascending within 1..65535");
    value_of[t + 1] = static_cast<uint16_t>(next);
  }
  return Status::success();
}

}  // namespace

Status unpackRankMed(const uint8_t* in, size_t table_size, cv::Mat& depth) {
  std::vector<uint16_t> value_of;
  if (Status s = unpackRankTable(in, table_size, value_of); !s) return s;
  const unsigned k = static_cast<unsigned>(table_size);
  const uint8_t* hi = in + 2 * table_size;
  const uint8_t* lo = hi + depth.total();
  std::vector<int> prev(depth.cols + 1, kHole), cur(depth.cols + 1, kHole);  // [0] is left of column 0
  int last = 0;
  for (int y = 0; y < depth.rows; ++y, std::swap(prev, cur)) {
    uint16_t* row = depth.ptr<uint16_t>(y);
    bool bad = false;  // checked once per row; until then an out-of-table rank only feeds arithmetic
    for (int x = 0; x < depth.cols; ++x) {
      const int symbol = (*hi++ << 8) | *lo++;
      const int rank = predictRank(cur[x] == kHole, prev[x + 1], prev[x], last) + unzigzag(symbol - 1);
      const bool in_table = static_cast<unsigned>(rank) < k;
      bad |= symbol != 0 && !in_table;
      row[x] = value_of[symbol != 0 && in_table ? rank + 1 : 0];
      last = symbol != 0 ? rank : last;
      cur[x + 1] = symbol != 0 ? rank : kHole;
    }
    if (bad)
      return Status::failure("depth blob: a symbol in row " + std::to_string(y) +
                             " points outside the rank table");
  }
  return Status::success();
}

}  // namespace rgbdmap::detail
