#pragma once
// Disjoint sets of indices 0..n-1 (path halving); the root of a set is its smallest index. Used for the
// pose graph's components and a bundle adjustment's parts.
#include <algorithm>
#include <cstddef>
#include <numeric>
#include <vector>

namespace rgbdmap {

class UnionFind {
 public:
  explicit UnionFind(size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), size_t{0}); }
  size_t find(size_t i) {
    while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
    return i;
  }
  /// Joins the sets of a and b; false when they were one set already.
  bool join(size_t a, size_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    parent_[std::max(a, b)] = std::min(a, b);
    return true;
  }

 private:
  std::vector<size_t> parent_;
};

}  // namespace rgbdmap
