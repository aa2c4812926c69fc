#include "inbox.hpp"

#include <algorithm>

#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap {

Inbox::Inbox(const MapServerConfig& config, const msg::KeyStore& keys, RobotRegistry& registry,
             IngestQueue& queue)
    : config_(config), keys_(keys), registry_(registry), queue_(queue) {}

void Inbox::onMessage(const std::string& channel, const uint8_t* data, size_t size) {
  std::string robot, suffix;
  if (!msg::splitChannel(channel, &robot, &suffix)) return;
  const bool to_server = suffix == msg::channelSuffix(msg::MessageType::kHello) ||
                         suffix == msg::channelSuffix(msg::MessageType::kHeartbeat) ||
                         suffix == msg::channelSuffix(msg::MessageType::kKeyframe) ||
                         suffix == msg::channelSuffix(msg::MessageType::kKeyframeChunk);
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
    case msg::MessageType::kKeyframeChunk:
      return onChunk(*opened, robot);
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
  auto keyframe = msg::decodeMessage<msg::Keyframe>(opened, &rejects_);
  if (!keyframe) return;
  if (keyframe->robot_id != robot) {
    rejects_.add(msg::RejectReason::kInvalidContent,
                 "keyframe for '" + keyframe->robot_id + "' from " + robot);
    return;
  }
  queue_.pushKeyframe(std::move(*keyframe));
}

}  // namespace rgbdmap
