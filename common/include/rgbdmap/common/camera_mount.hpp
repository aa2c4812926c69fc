#pragma once
// Where the camera sits on the robot: T_base_camera, the camera's optical frame (x right, y down, z forward)
// in the robot's base frame (REP-103: x forward, y left, z up). The map frame is the base frame of the first
// robot's first keyframe, so maps are z-up whatever the camera looks like.
//
// Configured as ROS URDFs do: the pose of a camera *body* frame (x forward along the optical axis, y left,
// z up) in the base frame, translation xyz_m and fixed-axis roll/pitch/yaw rpy_deg (R = Rz(yaw) Ry(pitch)
// Rx(roll)); the optical rotation follows from it. All zero: a level camera at the base's origin looking
// forward (camera z = base x, camera x = base -y, camera y = base -z). A camera 0.4 m up, tilted 10 degrees
// down: xyz_m [0, 0, 0.4], rpy_deg [0, 10, 0].
#include <array>
#include <string>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// Rotation of the optical frame in the camera body frame: columns = optical x, y, z in body coordinates
/// ((0, -1, 0), (0, 0, -1), (1, 0, 0)).
Mat3 R_body_optical();

struct CameraMount {
  std::array<double, 3> xyz_m{0.0, 0.0, 0.0};    ///< camera position in the base frame
  std::array<double, 3> rpy_deg{0.0, 0.0, 0.0};  ///< roll, pitch, yaw of the camera body in the base frame

  /// T_base_camera (camera = optical frame).
  SE3 T_base_camera() const;
  /// Empty when valid (finite, |xyz| <= kMaxCameraOffsetM, angles within +-360), else every reason.
  std::string validate() const;
};

constexpr double kMaxCameraOffsetM = 100.0;  ///< also the bound Hello's T_base_camera is checked against

/// The default mount's T_base_camera: a level, forward-looking camera at the base's origin.
SE3 defaultT_base_camera();

}  // namespace rgbdmap
