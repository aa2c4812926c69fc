#include "rgbdmap/common/camera.hpp"

#include "rgbdmap/common/common_config_tables.hpp"

#include <cmath>
#include <sstream>

namespace rgbdmap {

std::string CameraIntrinsics::validate() const { return joinProblems(cameraConfigTable().problems(*this)); }

bool sameIntrinsics(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.width == b.width &&
         a.height == b.height && a.distortion == b.distortion && a.depth_scale == b.depth_scale &&
         a.readout_s == b.readout_s;
}

bool CameraIntrinsics::hasDistortion() const {
  for (double d : distortion)
    if (d != 0.0) return true;
  return false;
}

PinholeCamera::PinholeCamera(const CameraIntrinsics& intrinsics)
    : k_(intrinsics), distorted_(intrinsics.hasDistortion()) {}

std::optional<Eigen::Vector2d> PinholeCamera::project(const Eigen::Vector3d& p_cam) const {
  if (!(p_cam.z() > 1e-9)) return std::nullopt;
  return Eigen::Vector2d(k_.fx * p_cam.x() / p_cam.z() + k_.cx, k_.fy * p_cam.y() / p_cam.z() + k_.cy);
}

std::optional<Eigen::Vector2d> PinholeCamera::projectDistorted(const Eigen::Vector3d& p_cam) const {
  auto ideal = project(p_cam);
  if (!ideal) return std::nullopt;
  return distort(*ideal);
}

Eigen::Vector2d PinholeCamera::distortNormalized(const Eigen::Vector2d& xn) const {
  const auto& d = k_.distortion;  // k1 k2 p1 p2 k3
  const double x = xn.x(), y = xn.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (d[0] + r2 * (d[1] + r2 * d[4]));
  const double dx = 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double dy = d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  return {x * radial + dx, y * radial + dy};
}

Eigen::Vector2d PinholeCamera::distort(const Eigen::Vector2d& ideal_px) const {
  if (!distorted_) return ideal_px;
  const Eigen::Vector2d xn((ideal_px.x() - k_.cx) / k_.fx, (ideal_px.y() - k_.cy) / k_.fy);
  const Eigen::Vector2d xd = distortNormalized(xn);
  return {k_.fx * xd.x() + k_.cx, k_.fy * xd.y() + k_.cy};
}

Eigen::Vector2d PinholeCamera::undistort(const Eigen::Vector2d& raw_px) const {
  if (!distorted_) return raw_px;
  const Eigen::Vector2d xd((raw_px.x() - k_.cx) / k_.fx, (raw_px.y() - k_.cy) / k_.fy);
  // Fixed-point iteration x <- xd - (distort(x) - x), as OpenCV's undistortPoints does.
  Eigen::Vector2d x = xd;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector2d err = distortNormalized(x) - xd;
    x -= err;
    if (err.squaredNorm() < 1e-20) break;
  }
  return {k_.fx * x.x() + k_.cx, k_.fy * x.y() + k_.cy};
}

Eigen::Vector3d PinholeCamera::backProject(const Eigen::Vector2d& ideal_px, double depth_m) const {
  return {(ideal_px.x() - k_.cx) / k_.fx * depth_m, (ideal_px.y() - k_.cy) / k_.fy * depth_m, depth_m};
}

Eigen::Vector3d PinholeCamera::backProjectRaw(const Eigen::Vector2d& raw_px, double depth_m) const {
  return backProject(undistort(raw_px), depth_m);
}

bool PinholeCamera::inImage(const Eigen::Vector2d& px, double border) const {
  return px.x() >= border && px.y() >= border && px.x() < k_.width - border && px.y() < k_.height - border;
}

}  // namespace rgbdmap
