#pragma once
// Consistency of a new keyframe's verified loop edges with the loops verified earlier among their targets:
// for edges X->A and X->B and a stored verified edge between B and A, T_X_A must agree with T_X_B * T_B_A.
// No pose estimate enters (drift does not matter), only verified measurements. An edge contradicted by
// most of its triangles is a partly aliased match whose pose is biased even though the views overlap.
#include <map>
#include <utility>
#include <vector>

#include "rgbdmap/loop/loop_verifier.hpp"

namespace rgbdmap {

struct LoopConsistencyConfig {
  /// Triangles closing worse than this are contradictions. Measured on fr1_rpy: true triangles close
  /// within 5.0 cm / 2.3 deg; a partly aliased synthetic edge was 14.5 cm / 3 deg off.
  double max_translation_m = 0.08;
  double max_rotation_deg = 4.0;
  int min_triangles = 2;  ///< edges with fewer triangles are kept (nothing to check against)
};

/// Accepted loop edges by (from_id, to_id): T_from_to.
class LoopEdgeStore {
 public:
  void add(const LoopEdge& e) { T_from_to_[{e.from_id, e.to_id}] = e.T_from_to; }
  /// T_a_b if an edge a->b or b->a is stored.
  bool relative(int a, int b, SE3* T_a_b) const;

 private:
  std::map<std::pair<int, int>, SE3> T_from_to_;
};

/// Per edge (same order): true if kept. All edges must share from_id.
std::vector<char> checkEdgeConsistency(const std::vector<LoopEdge>& edges, const LoopEdgeStore& store,
                                       const LoopConsistencyConfig& config);

}  // namespace rgbdmap
