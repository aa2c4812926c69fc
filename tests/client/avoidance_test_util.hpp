#pragma once
// Slices for the avoidance tests, in the map convention of the project: the map frame is z-up (REP-103,
// the base frame of the first robot's first keyframe), up = (0, 0, 1); these robot-centred grids have x =
// the robot's forward, y = left, z = up (the server's are axis-aligned; the rule handles either).
#include <cmath>

#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::testing {

/// Rotation whose columns are forward, left, up (map frame) for a camera looking along forward_map.
inline Mat3 R_map_robot(const Vec3& forward_map, const Vec3& up_map = Vec3(0, 0, 1)) {
  const Vec3 up = up_map.normalized();
  const Vec3 f = (forward_map - up * up.dot(forward_map)).normalized();
  Mat3 R;
  R.col(0) = f;
  R.col(1) = up.cross(f);
  R.col(2) = up;
  return R;
}

/// Camera at `position` (map frame), level, looking along the map direction `forward_map`.
inline SE3 levelCamera(const Vec3& position, const Vec3& forward_map) {
  const Mat3 R = R_map_robot(forward_map);
  SE3 T = SE3::Identity();
  T.linear().col(2) = R.col(0);   // camera z = forward
  T.linear().col(0) = -R.col(1);  // camera x = right
  T.linear().col(1) = -R.col(2);  // camera y = down
  T.translation() = position;
  return T;
}

/// A side x side metre grid at `res`, axes aligned with the camera's forward/left, centred on the camera,
/// every cell set to `fill`.
inline msg::OccupancySlice robotCentredSlice(const SE3& T_map_cam, double side_m, double res, int8_t fill) {
  msg::OccupancySlice s;
  s.robot_id = "robot0";
  s.resolution_m = static_cast<float>(res);
  s.width = s.height = static_cast<int>(std::lround(side_m / res));
  s.cells.assign(static_cast<size_t>(s.width) * s.height, fill);
  const Mat3 R = R_map_robot(T_map_cam.linear().col(2));
  s.T_map_grid.linear() = R;
  s.T_map_grid.translation() = T_map_cam.translation() - R * Vec3(side_m / 2, side_m / 2, 0.0);
  return s;
}

/// Sets the cell containing the map point p (projected onto the grid) to value; false if outside.
inline bool setCellAt(msg::OccupancySlice* s, const Vec3& p_map, int8_t value) {
  const Vec3 g = s->T_map_grid.inverse() * p_map;
  const int col = static_cast<int>(std::floor(g.x() / s->resolution_m));
  const int row = static_cast<int>(std::floor(g.y() / s->resolution_m));
  if (col < 0 || row < 0 || col >= s->width || row >= s->height) return false;
  s->cells[static_cast<size_t>(row) * s->width + col] = value;
  return true;
}

}  // namespace rgbdmap::testing
