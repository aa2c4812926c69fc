// RobotLink: what visualisers and the monitor read from the robot, best effort: the live pose (RobotPose,
// throttled) and the link's delivery state (LinkStatus, once a heartbeat period).
#include <algorithm>

#include "robot_link_impl.hpp"
#include "wall_clock.hpp"

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

msg::LinkStatus RobotLink::Impl::linkStatus() const {
  const RobotLinkStats s = stats();
  msg::LinkStatus m;
  m.robot_id = options_.robot_id;
  m.keyframes_made =
      static_cast<int>(s.keyframes_spooled + s.keyframes_live_only + (spool_ ? 0 : s.keyframes_sent));
  m.keyframes_acked = static_cast<int>(s.keyframes_acked - s.recovered_acked);
  m.queued = static_cast<int>(s.keyframes_queued);
  m.in_flight = static_cast<int>(reliable_.pending());
  m.spool_depth = spool_ ? static_cast<int>(s.spool_depth) : -1;
  m.spool_bytes = static_cast<int64_t>(s.spool_bytes);
  const auto now = Clock::now();
  double oldest = s.spool_oldest_utime > 0 ? (nowUtime() - s.spool_oldest_utime) * 1e-6 : 0.0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, entry] : sent_)
      if (entry.answer == Answer::kPending && entry.fed && !entry.spooled)
        oldest = std::max(oldest, std::chrono::duration<double>(now - entry.first_sent).count());
    m.live_only = live_only_;
  }
  m.oldest_unanswered_s = std::max(0.0, oldest);
  m.diagnosis = s.diagnosis;
  return m;
}

Status RobotLink::Impl::sendLinkStatus() {
  Status s = sealAndPublish(linkStatus(), link_status_channel_);
  if (s) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counts_.link_status_sent;
  }
  return s;
}

}  // namespace rgbdmap
