#include "rgbdmap/common/camera_mount.hpp"

#include <cmath>

#include "rgbdmap/common/common_config_tables.hpp"

namespace rgbdmap {

Mat3 R_body_optical() {
  Mat3 R;
  R << 0, 0, 1,  //
      -1, 0, 0,  //
      0, -1, 0;
  return R;
}

SE3 CameraMount::T_base_camera() const {
  constexpr double kDeg = M_PI / 180.0;
  const Mat3 R_base_body = (Eigen::AngleAxisd(rpy_deg[2] * kDeg, Vec3::UnitZ()) *
                            Eigen::AngleAxisd(rpy_deg[1] * kDeg, Vec3::UnitY()) *
                            Eigen::AngleAxisd(rpy_deg[0] * kDeg, Vec3::UnitX()))
                               .toRotationMatrix();
  SE3 T = SE3::Identity();
  T.linear() = R_base_body * R_body_optical();
  T.translation() = Vec3(xyz_m[0], xyz_m[1], xyz_m[2]);
  return se3::normalized(T);
}

std::string CameraMount::validate() const {
  std::vector<std::string> problems = cameraMountConfigTable().problems(*this);
  if (!(Vec3(xyz_m[0], xyz_m[1], xyz_m[2]).norm() <= kMaxCameraOffsetM))
    problems.push_back("xyz_m must be within " + std::to_string(kMaxCameraOffsetM) + " m of the base");
  for (double a : rpy_deg)
    if (!(std::abs(a) <= 360.0)) problems.push_back("rpy_deg must be within [-360, 360]");
  return joinProblems(problems);
}

SE3 defaultT_base_camera() { return CameraMount{}.T_base_camera(); }

}  // namespace rgbdmap
