#include "rgbdmap/workers/robot_publisher.hpp"

#include <chrono>

#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

RobotPublisher::RobotPublisher(transport::Transport& transport, const msg::KeyStore& keys,
                               int64_t server_session, RobotRegistry& registry)
    : transport_(transport), keys_(keys), server_session_(server_session), registry_(registry) {}

void RobotPublisher::acknowledge(const std::string& robot_id, int keyframe_id, bool accepted,
                                 const std::string& reason) {
  msg::KeyframeAck ack;
  ack.robot_id = robot_id;
  ack.keyframe_id = keyframe_id;
  ack.accepted = accepted;
  ack.reason = reason.substr(0, msg::kMaxTextLength);
  publish(robot_id, ack);
}

void RobotPublisher::publishNotice(const std::string& robot_id, const msg::ServerStatus& notice) {
  const auto channel = msg::channelFor(msg::ServerStatus::kType, robot_id);
  if (!channel) return;
  std::lock_guard<std::mutex> lock(mutex_);
  const auto bytes = notice_signer_.seal(notice, nowUtime());
  if (!bytes) return log::warn("server: cannot seal a notice for ", robot_id, ": ", bytes.error());
  publishLocked(*channel, *bytes);
}

int64_t RobotPublisher::nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

msg::Signer& RobotPublisher::signerFor(const std::string& robot_id) {
  auto& signer = signers_[robot_id];
  if (!signer) {
    const msg::Bytes* key = keys_.find(robot_id);
    signer = std::make_unique<msg::Signer>(msg::kServerId, key ? *key : msg::Bytes{}, server_session_);
  }
  return *signer;
}

bool RobotPublisher::publishLocked(const std::string& channel, const msg::Bytes& bytes) {
  if (const Status s = transport_.publish(channel, bytes); !s) {
    log::warn("server: publish on ", channel, " failed: ", s.error());
    return false;
  }
  return true;
}

void RobotPublisher::sendLocked(const std::string& robot_id, const std::string& channel,
                                const msg::Bytes& bytes) {
  if (publishLocked(channel, bytes)) registry_.addBytesSent(robot_id, bytes.size());
}

}  // namespace rgbdmap
