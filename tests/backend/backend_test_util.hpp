#pragma once
// Pose-graph edges and nodes for the back-end tests.
#include <cstdint>

#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap::testing {

inline PoseGraphEdge backendEdge(int64_t id, int64_t from, int64_t to, const SE3& T_from_to, EdgeKind kind,
                                 double sigma_t = 0.01, double sigma_r = 0.005) {
  PoseGraphEdge e;
  e.id = id;
  e.from = from;
  e.to = to;
  e.T_from_to = T_from_to;
  e.kind = kind;
  e.information.setZero();
  e.information.diagonal() << Vec3::Constant(1.0 / (sigma_t * sigma_t)),
      Vec3::Constant(1.0 / (sigma_r * sigma_r));
  return e;
}

inline SE3 along(double x) {
  SE3 T = SE3::Identity();
  T.translation() = Vec3(x, 0.0, 0.0);
  return T;
}

}  // namespace rgbdmap::testing
