#include "rgbdmap/loop/loop_consistency.hpp"

#include <cmath>

namespace rgbdmap {

bool LoopEdgeStore::relative(int a, int b, SE3* T_a_b) const {
  if (const auto it = T_from_to_.find({a, b}); it != T_from_to_.end()) {
    *T_a_b = it->second;
    return true;
  }
  if (const auto it = T_from_to_.find({b, a}); it != T_from_to_.end()) {
    *T_a_b = it->second.inverse();
    return true;
  }
  return false;
}

std::vector<char> checkEdgeConsistency(const std::vector<LoopEdge>& edges, const LoopEdgeStore& store,
                                       const LoopConsistencyConfig& config) {
  std::vector<char> keep(edges.size(), 1);
  for (size_t a = 0; a < edges.size(); ++a) {
    int triangles = 0, contradictions = 0;
    for (size_t b = 0; b < edges.size(); ++b) {
      SE3 T_B_A;
      if (a == b || !store.relative(edges[b].to_id, edges[a].to_id, &T_B_A)) continue;
      const SE3 mismatch = edges[a].T_from_to.inverse() * edges[b].T_from_to * T_B_A;
      ++triangles;
      if (mismatch.translation().norm() > config.max_translation_m ||
          se3::rotationAngle(mismatch) > config.max_rotation_deg * M_PI / 180.0)
        ++contradictions;
    }
    if (triangles >= config.min_triangles && 2 * contradictions > triangles) keep[a] = 0;
  }
  return keep;
}

}  // namespace rgbdmap
