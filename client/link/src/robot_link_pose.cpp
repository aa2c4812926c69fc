// RobotLink::publishPose: the robot's live pose for visualisers (RobotPose, best effort, throttled).
#include <algorithm>

#include "robot_link_impl.hpp"

namespace rgbdmap {

Status RobotLink::Impl::publishPose(double timestamp, int segment, int reference_keyframe,
                                    TrackingState state, const SE3& T_odom_cam) {
  if (options_.pose_period_s <= 0.0) return Status::success();
  const Clock::time_point now = Clock::now();
  {
    std::lock_guard<std::mutex> lock(pose_mutex_);
    if (last_pose_ && std::chrono::duration<double>(now - *last_pose_).count() < options_.pose_period_s)
      return Status::success();
    last_pose_ = now;
  }
  msg::RobotPose pose;
  pose.robot_id = options_.robot_id;
  pose.timestamp = timestamp;
  pose.segment_id = segment;
  pose.reference_keyframe_id = std::max(-1, reference_keyframe);
  pose.tracking_state = static_cast<int>(state);
  pose.T_map_cam = se3::normalized(mapFromOdom(segment) * T_odom_cam);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!started_ || stopping_) return Status::failure("publishPose: link not running");
    pose.graph_revision = graph_revision_;
  }
  Status s = sealAndPublish(pose, pose_channel_);
  if (s) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counts_.poses_sent;
  }
  return s;
}

}  // namespace rgbdmap
