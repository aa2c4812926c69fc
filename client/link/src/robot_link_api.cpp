// RobotLink: the public class forwards to RobotLink::Impl (robot_link_impl.hpp).
#include "robot_link_impl.hpp"

namespace rgbdmap {

// ---- RobotLink: forwards to Impl ----

RobotLink::RobotLink(transport::Transport& transport, RobotLinkOptions options)
    : impl_(std::make_shared<Impl>(transport, std::move(options))) {}
RobotLink::~RobotLink() { impl_->stop(); }
Status RobotLink::start() { return impl_->start(); }
void RobotLink::stop() { impl_->stop(); }
Status RobotLink::sendKeyframe(const Keyframe& keyframe, const RgbdFrame& frame) {
  return impl_->sendKeyframe(keyframe, frame);
}
Status RobotLink::sendKeyframeMessage(msg::Keyframe message) {
  return impl_->sendKeyframeMessage(std::move(message));
}
void RobotLink::setTrackingState(int last_keyframe_id, int segment, TrackingState state) {
  impl_->setTrackingState(last_keyframe_id, segment, state);
}
SE3 RobotLink::mapFromOdom(int segment) const { return impl_->mapFromOdom(segment); }
std::optional<SE3> RobotLink::correctedKeyframe(int keyframe_id) const {
  return impl_->correctedKeyframe(keyframe_id);
}
Status RobotLink::publishPose(double timestamp, int segment, int reference_keyframe, TrackingState state,
                              const SE3& T_odom_cam) {
  return impl_->publishPose(timestamp, segment, reference_keyframe, state, T_odom_cam);
}
std::optional<msg::OccupancySlice> RobotLink::latestSlice() const { return impl_->latest(&Impl::slice_); }
Status RobotLink::publishCommand(const msg::VelocityCommand& command) {
  return impl_->publishCommand(command);
}
std::optional<msg::VelocityCommand> RobotLink::latestCommand() const {
  return impl_->latest(&Impl::command_);
}
std::optional<msg::ServerStatus> RobotLink::latestServerStatus() const {
  return impl_->latest(&Impl::status_);
}
bool RobotLink::waitAllAcked(double timeout_s) { return impl_->waitAllAcked(timeout_s); }
bool RobotLink::waitForCorrection(int keyframe_id, double timeout_s) {
  return impl_->waitForCorrection(keyframe_id, timeout_s);
}
bool RobotLink::waitForGraphRevision(int64_t revision, double timeout_s) {
  return impl_->waitForGraphRevision(revision, timeout_s);
}
RobotLinkStats RobotLink::stats() const { return impl_->stats(); }
std::map<int, int64_t> RobotLink::keyframeAckTimes() const { return impl_->keyframeAckTimes(); }

}  // namespace rgbdmap
