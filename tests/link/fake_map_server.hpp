#pragma once
// A small stand-in for the mapping server in the RobotLink tests: subscribes one robot's hello, heartbeat and
// keyframe channels (own KeyStore and ReplayGuard), stores keyframes by id (duplicates acknowledged again,
// stored once), acknowledges them (optionally ignoring the first N transmissions, or refusing some ids) and
// answers each newly stored keyframe with PoseCorrections T_map_cam(k) = T_map_odom(segment) * T_odom_cam(k).
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include "link_test_util.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::testing {

struct FakeServerOptions {
  std::string robot_id = "robot0";
  msg::Bytes verify_key;  ///< key_R the server verifies the robot with; empty = open mode
  msg::Bytes sign_key;    ///< key it signs its answers with (normally key_R; another one for forgery tests)
  int ignore_first_transmissions = 0;  ///< keyframe messages dropped before any processing (lost on the way)
  std::set<int> refuse_ids;            ///< acknowledged with accepted = false
  bool ack = true;
  int acks_per_keyframe = 1;  ///< > 1: every ack is sent that many times (duplicates)
  bool send_corrections = true;
  std::map<int, SE3> T_map_odom;  ///< per segment; identity when absent
};

class FakeMapServer {
 public:
  struct State {
    std::mutex mutex;
    std::condition_variable cv;
    std::map<int, msg::Keyframe> stored;
    std::map<int, int> receptions;  ///< keyframe messages that reached processing, by id
    int transmissions = 0;          ///< every keyframe message, dropped ones included
    int hellos = 0, heartbeats = 0;
    msg::Hello last_hello;
    msg::Heartbeat last_heartbeat;
    std::vector<msg::RobotPose> poses;  ///< the robot's live poses (a visualiser's view)
    int64_t revision = 0;
  };

  FakeMapServer(transport::Transport& transport, FakeServerOptions options)
      : core_(std::make_shared<Core>(transport, std::move(options))) {}

  /// Subscribes the robot's channels; the handlers keep the server's state alive as long as the transport.
  void start() {
    auto core = core_;
    const std::string& r = core->options.robot_id;
    core->transport.subscribe(
        msg::channelFor(msg::MessageType::kKeyframe, r).value(),
        [core](const std::string&, const uint8_t* d, size_t n) { core->onKeyframe(d, n); });
    core->transport.subscribe(
        msg::channelFor(msg::MessageType::kHello, r).value(),
        [core](const std::string&, const uint8_t* d, size_t n) { core->onHello(d, n); });
    core->transport.subscribe(
        msg::channelFor(msg::MessageType::kHeartbeat, r).value(),
        [core](const std::string&, const uint8_t* d, size_t n) { core->onHeartbeat(d, n); });
    core->transport.subscribe(msg::channelFor(msg::MessageType::kRobotPose, r).value(),
                              [core](const std::string&, const uint8_t* d, size_t n) { core->onPose(d, n); });
    core->transport.start();
  }

  State& state() { return core_->state; }
  msg::RejectCounters& rejects() { return core_->rejects; }
  /// Seals with the server's signer (sender "server", sign_key) and publishes on the robot's channel.
  template <typename T>
  Status send(const T& message) {
    return core_->send(message);
  }
  /// Waits (condition variable) until pred(state) holds; false on timeout.
  template <typename Pred>
  bool waitFor(Pred pred, double timeout_s = 5.0) {
    std::unique_lock<std::mutex> lock(core_->state.mutex);
    return core_->state.cv.wait_for(lock, std::chrono::duration<double>(timeout_s),
                                    [&] { return pred(core_->state); });
  }

 private:
  struct Core {
    Core(transport::Transport& t, FakeServerOptions o)
        : transport(t),
          options(std::move(o)),
          keys(makeKeys(options)),
          signer(msg::kServerId, options.sign_key) {}
    static msg::KeyStore makeKeys(const FakeServerOptions& o) {
      if (o.verify_key.empty()) return msg::KeyStore::openMode();
      msg::KeyStore k;
      (void)k.add(o.robot_id, o.verify_key);
      return k;
    }
    template <typename T>
    Status send(const T& message) {
      std::lock_guard<std::mutex> lock(signer_mutex);
      Result<msg::Bytes> bytes = signer.seal(message, 1);
      if (!bytes) return Status::failure(bytes.error());
      return transport.publish(msg::channelFor(T::kType, options.robot_id).value(), *bytes);
    }
    template <typename T>
    Result<T> open(const uint8_t* data, size_t size) {
      auto env = msg::openEnvelope(data, size, keys, &guard, &rejects);
      if (!env) return Result<T>::failure(env.error());
      return msg::decodeMessage<T>(*env, &rejects);
    }
    void onHello(const uint8_t* data, size_t size) {
      auto hello = open<msg::Hello>(data, size);
      if (!hello) return;
      std::lock_guard<std::mutex> lock(state.mutex);
      ++state.hellos;
      state.last_hello = *hello;
      state.cv.notify_all();
    }
    void onPose(const uint8_t* data, size_t size) {
      auto pose = open<msg::RobotPose>(data, size);
      if (!pose) return;
      std::lock_guard<std::mutex> lock(state.mutex);
      state.poses.push_back(*pose);
      state.cv.notify_all();
    }
    void onHeartbeat(const uint8_t* data, size_t size) {
      auto hb = open<msg::Heartbeat>(data, size);
      if (!hb) return;
      std::lock_guard<std::mutex> lock(state.mutex);
      ++state.heartbeats;
      state.last_heartbeat = *hb;
      state.cv.notify_all();
    }
    void onKeyframe(const uint8_t* data, size_t size) {
      {
        std::lock_guard<std::mutex> lock(state.mutex);
        const bool drop = state.transmissions++ < options.ignore_first_transmissions;
        state.cv.notify_all();
        if (drop) return;
      }
      auto kf = open<msg::Keyframe>(data, size);
      if (!kf) return;
      bool is_new = false;
      {
        std::lock_guard<std::mutex> lock(state.mutex);
        ++state.receptions[kf->keyframe_id];
        is_new = state.stored.emplace(kf->keyframe_id, *kf).second;
        state.cv.notify_all();
      }
      if (options.ack) {
        const bool accepted = options.refuse_ids.count(kf->keyframe_id) == 0;
        for (int i = 0; i < options.acks_per_keyframe; ++i)
          (void)send(makeAck(options.robot_id, kf->keyframe_id, accepted, accepted ? "" : "test refusal"));
      }
      if (is_new && options.send_corrections) sendCorrections();
    }
    void sendCorrections() {
      msg::PoseCorrections c;
      c.robot_id = options.robot_id;
      {
        std::lock_guard<std::mutex> lock(state.mutex);
        c.graph_revision = ++state.revision;
        for (const auto& [id, kf] : state.stored) {
          if (options.refuse_ids.count(id)) continue;
          c.keyframes.push_back({id, segmentTransform(kf.segment_id) * kf.T_odom_cam});
          c.T_map_odom = segmentTransform(kf.segment_id);
        }
      }
      (void)send(c);
    }
    SE3 segmentTransform(int segment) const {
      auto it = options.T_map_odom.find(segment);
      return it == options.T_map_odom.end() ? SE3::Identity() : it->second;
    }

    transport::Transport& transport;
    FakeServerOptions options;
    msg::KeyStore keys;
    msg::ReplayGuard guard;
    msg::RejectCounters rejects;
    std::mutex signer_mutex;
    msg::Signer signer;
    State state;
  };
  std::shared_ptr<Core> core_;
};

/// Options of a fake server that verifies and signs with `key`.
inline FakeServerOptions serverOptions(const msg::Bytes& key) {
  FakeServerOptions o;
  o.verify_key = key;
  o.sign_key = key;
  return o;
}

/// Sends keyframes first_id .. first_id + count - 1 of a segment (small test keyframes on testPose(i)).
inline void sendKeyframes(RobotLink& link, int count, int segment = 0, int first_id = 0) {
  for (int i = first_id; i < first_id + count; ++i) {
    const Status s = link.sendKeyframe(smallKeyframe(i, segment, testPose(i)), smallFrame(i));
    ASSERT_TRUE(s) << s.error();
  }
}

}  // namespace rgbdmap::testing
