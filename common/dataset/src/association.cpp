#include "rgbdmap/dataset/association.hpp"

#include <algorithm>
#include <cmath>

namespace rgbdmap {
namespace {

struct Candidate {
  double diff;
  size_t a;
  size_t b;
};

/// Indices of the finite entries of `t`, sorted by timestamp.
std::vector<size_t> sortedFiniteIndices(const std::vector<double>& t) {
  std::vector<size_t> idx;
  idx.reserve(t.size());
  for (size_t i = 0; i < t.size(); ++i)
    if (std::isfinite(t[i])) idx.push_back(i);
  std::stable_sort(idx.begin(), idx.end(), [&t](size_t x, size_t y) { return t[x] < t[y]; });
  return idx;
}

/// All (a, b) with |t_a - t_b| < max_dt, found by a binary search per a instead of the O(n m) scan.
std::vector<Candidate> candidates(const std::vector<double>& ta, const std::vector<double>& tb,
                                  double max_dt) {
  const std::vector<size_t> b_sorted = sortedFiniteIndices(tb);
  std::vector<Candidate> out;
  for (size_t a = 0; a < ta.size(); ++a) {
    if (!std::isfinite(ta[a])) continue;
    auto it = std::lower_bound(b_sorted.begin(), b_sorted.end(), ta[a] - max_dt,
                               [&tb](size_t b, double value) { return tb[b] < value; });
    for (; it != b_sorted.end() && tb[*it] <= ta[a] + max_dt; ++it) {
      const double diff = std::abs(ta[a] - tb[*it]);
      if (diff < max_dt) out.push_back({diff, a, *it});
    }
  }
  return out;
}

}  // namespace

std::vector<IndexPair> associate(const std::vector<double>& a_timestamps,
                                 const std::vector<double>& b_timestamps, double max_dt) {
  if (!(max_dt > 0)) return {};
  std::vector<Candidate> cand = candidates(a_timestamps, b_timestamps, max_dt);
  const auto& ta = a_timestamps;
  const auto& tb = b_timestamps;
  std::sort(cand.begin(), cand.end(), [&](const Candidate& x, const Candidate& y) {
    if (x.diff != y.diff) return x.diff < y.diff;
    if (ta[x.a] != ta[y.a]) return ta[x.a] < ta[y.a];
    if (tb[x.b] != tb[y.b]) return tb[x.b] < tb[y.b];
    return x.a != y.a ? x.a < y.a : x.b < y.b;
  });
  std::vector<char> a_used(ta.size(), 0), b_used(tb.size(), 0);
  std::vector<IndexPair> matches;
  for (const Candidate& c : cand) {
    if (a_used[c.a] || b_used[c.b]) continue;
    a_used[c.a] = b_used[c.b] = 1;
    matches.push_back({c.a, c.b});
  }
  std::sort(matches.begin(), matches.end(), [&](const IndexPair& x, const IndexPair& y) {
    if (ta[x.a] != ta[y.a]) return ta[x.a] < ta[y.a];
    return tb[x.b] != tb[y.b] ? tb[x.b] < tb[y.b] : x.a < y.a;
  });
  return matches;
}

}  // namespace rgbdmap
