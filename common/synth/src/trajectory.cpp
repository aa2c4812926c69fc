// Camera paths of the synthetic scenes, parameterised over the whole sequence so that any frame count
// covers the full path. Smooth (C-infinity) in time; the loop ends exactly at its start pose.
#include <cmath>

#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap {
namespace {

constexpr double kTwoPi = 6.283185307179586;

/// Camera pose from its position and heading: yaw about world z (0 = looking along +x), pitch > 0 looks
/// up, roll about the viewing direction. The camera frame is optical: x right, y down, z forward.
SE3 cameraPose(const Vec3& position_world, double yaw, double pitch, double roll) {
  // Body frame: x forward, y left, z up.
  const Mat3 R_world_body =
      (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(-pitch, Vec3::UnitY()) *
       Eigen::AngleAxisd(roll, Vec3::UnitX()))
          .toRotationMatrix();
  Mat3 R_body_cam;
  R_body_cam << 0, 0, 1,  //
      -1, 0, 0,           //
      0, -1, 0;
  SE3 T_world_cam = SE3::Identity();
  T_world_cam.linear() = R_world_body * R_body_cam;
  T_world_cam.translation() = position_world;
  return T_world_cam;
}

/// Ellipse (0.9 m x 0.7 m) around the room centre at ~1.35 m, looking outward at the walls and furniture,
/// turning once; height, pitch and roll vary gently. s in [0, 1) is the fraction of the loop done.
SE3 loopPose(double s) {
  const double phi = kTwoPi * s;
  const Vec3 p(0.9 * std::cos(phi), 0.7 * std::sin(phi), 1.35 + 0.08 * std::sin(2.0 * phi));
  const double yaw = phi + 0.15 * std::sin(2.0 * phi);
  const double pitch = -0.12 + 0.08 * std::sin(3.0 * phi);
  const double roll = 0.04 * std::sin(2.0 * phi + 0.5);
  return cameraPose(p, yaw, pitch, roll);
}

/// A 1 m sideways sweep (to the left) with 0.3 m forward motion facing the +x wall (2.3-2.6 m away),
/// easing in and out, panning 6 degrees along with the motion. u in [0, 1] is the fraction done.
SE3 sweepPose(double u) {
  const double s = 0.5 - 0.5 * std::cos(0.5 * kTwoPi * u);  // eased progress, zero velocity at the ends
  const Vec3 p(0.4 + 0.3 * s, -0.5 + 1.0 * s, 1.3 + 0.05 * std::sin(0.5 * kTwoPi * u));
  const double yaw = -0.05 + 0.1 * s;
  const double pitch = -0.15 + 0.05 * std::sin(kTwoPi * u);
  const double roll = 0.03 * std::sin(0.5 * kTwoPi * u);
  return cameraPose(p, yaw, pitch, roll);
}

}  // namespace

Result<Trajectory> makeSynthTrajectory(const SynthConfig& config) {
  const std::string invalid = config.validate();
  if (!invalid.empty()) return Result<Trajectory>::failure("invalid synthetic config: " + invalid);
  const int last = config.frames - 1;
  Trajectory trajectory;
  trajectory.reserve(static_cast<size_t>(config.frames));
  for (int i = 0; i < config.frames; ++i) {
    // The loop's last frame uses s = 0 again, so it is bit-identical to the first pose.
    const SE3 T_world_cam = config.scene == "loop" ? loopPose(static_cast<double>(i % last) / last)
                                                   : sweepPose(static_cast<double>(i) / last);
    trajectory.push_back({config.colorTimestamp(i), T_world_cam});
  }
  return trajectory;
}

}  // namespace rgbdmap
