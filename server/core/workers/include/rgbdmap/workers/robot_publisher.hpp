#pragma once
// Everything the server sends goes to one robot's channel, sealed by a signer per robot (the robot's key,
// the server's session and that robot's sequence numbers): corrections, acknowledgements, status, slices
// and map updates. Thread-safe (the ingest worker, the map worker and the status thread publish).
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {

class RobotPublisher {
 public:
  /// All references must outlive the publisher; `registry` counts the bytes sent.
  RobotPublisher(transport::Transport& transport, const msg::KeyStore& keys, int64_t server_session,
                 RobotRegistry& registry);

  /// Seals `message` for robot_id and publishes it on the robot's channel; failures are logged.
  template <typename T>
  void publish(const std::string& robot_id, const T& message) {
    const auto channel = msg::channelFor(T::kType, robot_id);
    if (!channel) return;
    std::lock_guard<std::mutex> lock(mutex_);
    const auto bytes = signerFor(robot_id).seal(message, nowUtime());
    if (!bytes) {
      log::warn("server: cannot seal ", msg::toString(T::kType), " for ", robot_id, ": ", bytes.error());
      return;
    }
    sendLocked(robot_id, *channel, *bytes);
  }

  /// A notice to a robot the server does not serve (intake's RefusalNotices), unsigned: the server shares no
  /// key with it. Not counted as bytes sent to a robot.
  void publishNotice(const std::string& robot_id, const msg::ServerStatus& notice);

  /// KeyframeAck (reason cut to the message's text limit).
  void acknowledge(const std::string& robot_id, int keyframe_id, bool accepted, const std::string& reason);

 private:
  static int64_t nowUtime();
  msg::Signer& signerFor(const std::string& robot_id);  // caller holds mutex_
  bool publishLocked(const std::string& channel, const msg::Bytes& bytes);  ///< false (logged) on failure
  void sendLocked(const std::string& robot_id, const std::string& channel, const msg::Bytes& bytes);

  transport::Transport& transport_;
  const msg::KeyStore& keys_;
  const int64_t server_session_;
  RobotRegistry& registry_;
  std::mutex mutex_;
  std::map<std::string, std::unique_ptr<msg::Signer>> signers_;
  msg::Signer notice_signer_{msg::kServerId, msg::Bytes{}, server_session_};
};

}  // namespace rgbdmap
