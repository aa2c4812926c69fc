#include "rgbdmap/vision/matcher.hpp"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstring>

#include "hamming_kernels.hpp"

namespace rgbdmap {
namespace vision_detail {
namespace {

// Each train row gets the key (distance << 16) | row: the smallest key is the nearest row, the lowest on
// ties, and the minimum is a plain reduction the compiler vectorises. Masked rows get kFar.
constexpr uint32_t kFar = UINT32_MAX;
constexpr int kMaxKeyedRows = 1 << 16;

inline NearestTwo nearestBody(const uint64_t* query, const uint64_t* columns, int n, const char* mask,
                              uint32_t* key) {
  const uint64_t q0 = query[0], q1 = query[1], q2 = query[2], q3 = query[3];
  const uint64_t *c0 = columns, *c1 = columns + n, *c2 = columns + 2 * static_cast<size_t>(n),
                 *c3 = columns + 3 * static_cast<size_t>(n);
  for (int t = 0; t < n; ++t)
    key[t] = static_cast<uint32_t>(__builtin_popcountll(q0 ^ c0[t]) + __builtin_popcountll(q1 ^ c1[t]) +
                                   __builtin_popcountll(q2 ^ c2[t]) + __builtin_popcountll(q3 ^ c3[t]))
                 << 16 |
             static_cast<uint32_t>(t);
  if (mask)
    for (int t = 0; t < n; ++t) key[t] = mask[t] ? key[t] : kFar;
  uint32_t best = kFar;
  for (int t = 0; t < n; ++t) best = std::min(best, key[t]);
  if (best == kFar) return {};
  const int index = static_cast<int>(best & 0xFFFFu);
  key[index] = kFar;  // the second is the minimum of the others, ties included
  uint32_t second = kFar;
  for (int t = 0; t < n; ++t) second = std::min(second, key[t]);
  return {static_cast<int>(best >> 16), second == kFar ? INT_MAX : static_cast<int>(second >> 16), index};
}

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx512f,avx512vl,avx512bw,avx512vpopcntdq,popcnt"))) NearestTwo nearestAvx512(
    const uint64_t* query, const uint64_t* columns, int n, const char* mask, uint32_t* d) {
  return nearestBody(query, columns, n, mask, d);
}
__attribute__((target("popcnt"))) NearestTwo nearestPopcnt(const uint64_t* query, const uint64_t* columns,
                                                           int n, const char* mask, uint32_t* d) {
  return nearestBody(query, columns, n, mask, d);
}
#endif
NearestTwo nearestPlain(const uint64_t* query, const uint64_t* columns, int n, const char* mask, uint32_t* d) {
  return nearestBody(query, columns, n, mask, d);
}

using NearestFn = NearestTwo (*)(const uint64_t*, const uint64_t*, int, const char*, uint32_t*);

NearestFn pickNearest() {
#if defined(__x86_64__) && defined(__GNUC__)
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx512vpopcntdq") && __builtin_cpu_supports("avx512vl") &&
      __builtin_cpu_supports("avx512bw"))
    return nearestAvx512;
  if (__builtin_cpu_supports("popcnt")) return nearestPopcnt;
#endif
  return nearestPlain;
}

}  // namespace

NearestTwo nearestTwoOf(const uint64_t* query, const uint64_t* columns, int n, const char* mask,
                        uint32_t* scratch) {
  static const NearestFn fn = pickNearest();
  if (n < kMaxKeyedRows) return fn(query, columns, n, mask, scratch);
  NearestTwo out;  // more rows than a key can number: one row at a time
  for (int t = 0; t < n; ++t) {
    if (mask && !mask[t]) continue;
    const uint64_t row[4] = {columns[t], columns[n + t], columns[2 * static_cast<size_t>(n) + t],
                             columns[3 * static_cast<size_t>(n) + t]};
    out.offer(hamming256(query, row), t);
  }
  return out;
}

}  // namespace vision_detail

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("popcnt", "default")))
#endif
int hammingDistance(const uint8_t* a, const uint8_t* b) {
  uint64_t x[4], y[4];
  std::memcpy(x, a, 32);
  std::memcpy(y, b, 32);
  return vision_detail::hamming256(x, y);
}

std::vector<FeatureMatch> matchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                           const MatcherConfig& config, const std::vector<char>* train_mask) {
  std::vector<FeatureMatch> matches;
  if (query.empty() || train.empty()) return matches;
  CV_Assert(query.type() == CV_8U && train.type() == CV_8U && query.cols == 32 && train.cols == 32);
  const std::vector<uint64_t> q = vision_detail::packRows(query), t = vision_detail::packColumns(train);
  // Exhaustive search, one query row at a time.
  std::vector<vision_detail::NearestTwo> nearest(static_cast<size_t>(query.rows));
  std::vector<uint32_t> scratch(static_cast<size_t>(train.rows));
  for (int r = 0; r < query.rows; ++r)
    nearest[static_cast<size_t>(r)] = vision_detail::nearestTwoOf(
        &q[4 * static_cast<size_t>(r)], t.data(), train.rows, train_mask ? train_mask->data() : nullptr,
        scratch.data());

  int min_distance = INT_MAX;
  for (const auto& n : nearest)
    if (n.index >= 0) min_distance = std::min(min_distance, n.best);
  if (min_distance == INT_MAX) return matches;
  const double limit = std::min<double>(
      config.max_distance, std::max<double>(config.k_min_distance * min_distance, config.min_distance_floor));
  // One-to-one: the best query per train index wins.
  std::vector<int> owner(train.rows, -1);
  for (int i = 0; i < query.rows; ++i) {
    const vision_detail::NearestTwo& n = nearest[i];
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
