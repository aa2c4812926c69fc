#include "inbox.hpp"

#include <algorithm>

#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap {

Inbox::Inbox(const MapServerConfig& config, const msg::KeyStore& keys, RobotRegistry& registry,
             IngestQueue& queue)
    : config_(config),
      keys_(keys),
      registry_(registry),
      queue_(queue),
      throttle_(config.robot_max_keyframes_per_s, config.robot_keyframe_burst) {}

void Inbox::onMessage(const std::string& channel, const uint8_t* data, size_t size) {
  std::string robot, suffix;
  if (!msg::splitChannel(channel, &robot, &suffix)) return;
  const bool to_server = suffix == msg::channelSuffix(msg::MessageType::kHello) ||
                         suffix == msg::channelSuffix(msg::MessageType::kHeartbeat) ||
                         suffix == msg::channelSuffix(msg::MessageType::kKeyframe);
  if (!to_server) return;  // our own messages (udpm:// loops them back under a "rgbdmap/*" subscription)
  auto opened = msg::openEnvelope(data, size, keys_, &guard_, &rejects_);
  if (!opened) return;  // counted and logged (rate-limited) by RejectCounters
  if (opened->header.sender != robot) {
    rejects_.add(msg::RejectReason::kHeaderMismatch, "sender '" + opened->header.sender + "' on " + channel);
    return;
  }
  if (!admitted(robot)) {
    ++unknown_robot_;
    return;
  }
  registry_.addBytesReceived(robot, size, opened->header.utime);
  switch (opened->type) {
    case msg::MessageType::kHello:
      return onHello(*opened, robot);
    case msg::MessageType::kHeartbeat:
      (void)msg::decodeMessage<msg::Heartbeat>(*opened, &rejects_);
      return;
    case msg::MessageType::kKeyframe:
      return onKeyframe(*opened, robot);
    default:
      rejects_.add(msg::RejectReason::kWrongType,
                   std::string(msg::toString(opened->type)) + " on " + channel);
      return;
  }
}

bool Inbox::admitted(const std::string& robot) const {
  return config_.robots.empty() ||
         std::find(config_.robots.begin(), config_.robots.end(), robot) != config_.robots.end();
}

void Inbox::onHello(const msg::OpenedEnvelope& opened, const std::string& robot) {
  auto hello = msg::decodeMessage<msg::Hello>(opened, &rejects_);
  if (!hello) return;
  if (hello->robot_id != robot) {
    rejects_.add(msg::RejectReason::kInvalidContent, "hello for '" + hello->robot_id + "' from " + robot);
    return;
  }
  queue_.pushHello(std::move(*hello));
}

void Inbox::onKeyframe(const msg::OpenedEnvelope& opened, const std::string& robot) {
  // Authentic, not decoded yet: over the robot's rate, or no room in its queue, costs nothing more.
  if (!throttle_.allow(robot, KeyframeThrottle::Clock::now())) {
    ++throttled_;
    registry_.countThrottled(robot);
    queue_.demote(robot);
    return;
  }
  const size_t bytes = opened.payload.size();
  if (!queue_.hasRoom(robot, bytes)) return countQueueFull(robot);
  auto keyframe = msg::decodeMessage<msg::Keyframe>(opened, &rejects_);
  if (!keyframe) return;
  if (keyframe->robot_id != robot) {
    rejects_.add(msg::RejectReason::kInvalidContent,
                 "keyframe for '" + keyframe->robot_id + "' from " + robot);
    return;
  }
  if (queue_.pushKeyframe(std::move(*keyframe), bytes) == IngestQueue::Pushed::kFull) countQueueFull(robot);
}

void Inbox::countQueueFull(const std::string& robot) {
  ++queue_full_;
  registry_.countQueueFull(robot);
  queue_.demote(robot);
}

}  // namespace rgbdmap
