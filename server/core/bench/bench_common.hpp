#pragma once
// What the server benches share: the server they run (one robot, robot0, open mode, fdatasync on, one
// solver thread), robot0's Hello and a stand-in for its link (which keyframes the server acknowledged).
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::bench {

inline MapServerConfig serverConfig(const std::string& map_dir, bool occupancy) {
  MapServerConfig config;
  config.map_dir = map_dir;
  config.robots = {"robot0"};
  config.store_sync = true;
  config.graph.num_threads = 1;
  config.occupancy_enabled = occupancy;
  return config;
}

inline void sayHello(transport::Transport& transport, msg::Signer& signer, const CameraIntrinsics& camera) {
  msg::Hello hello;
  hello.robot_id = "robot0";
  hello.camera = camera;
  (void)transport.publish(*msg::channelFor(msg::MessageType::kHello, "robot0"),
                          signer.seal(hello, 1).value());
}

/// Subscribes robot0's keyframe acks (open mode: the benches' server runs without keys).
class AckWaiter {
 public:
  explicit AckWaiter(transport::Transport& transport) {
    (void)transport.subscribe(*msg::channelFor(msg::MessageType::kKeyframeAck, "robot0"),
                              [this](const std::string&, const uint8_t* data, size_t size) {
                                auto e = msg::openEnvelope(data, size, open_, &guard_);
                                if (!e) return;
                                auto ack = msg::decodeMessage<msg::KeyframeAck>(*e);
                                if (!ack) return;
                                std::lock_guard<std::mutex> lock(mutex_);
                                acked_.insert(ack->keyframe_id);
                                cv_.notify_all();
                              });
  }
  /// True once keyframe `id` is acknowledged; false after timeout_s.
  bool waitFor(int id, double timeout_s) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return acked_.count(id) > 0; });
  }

 private:
  msg::KeyStore open_ = msg::KeyStore::openMode();
  msg::ReplayGuard guard_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::set<int> acked_;
};

}  // namespace rgbdmap::bench
