#pragma once
// A keyframe as the robot's odometry makes it and the wire message carries it: pose in its odometry
// segment, features, and the odometry edge to its predecessor with the edge's information.
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

struct Keyframe {
  int id = 0;
  int segment = 0;  ///< odometry segment; a new one starts after a loss that relocalisation could not fix
  int frame_index = 0;
  double timestamp = 0.0;
  SE3 T_odom_cam = SE3::Identity();
  FrameFeatures features;
  int previous_id = -1;              ///< previous keyframe in the same segment, -1 for a segment start
  SE3 T_prev_cur = SE3::Identity();  ///< relative pose from the previous keyframe (odometry edge)
  /// Information of that edge, tangent order (rho, omega), for a right perturbation T_prev_cur * exp(xi)
  /// (the refinement's left perturbation of T_cur_prev).
  Mat6 information = Mat6::Zero();
};

}  // namespace rgbdmap
