#pragma once
// Shared by the server tests: the recorded odometry keyframes of the synthetic loop, a scripted robot that
// speaks the real protocol (signed Hello and Keyframes, acks and corrections back), and the server harness.
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "common/temp_dir.hpp"
#include "proto/proto_test_util.hpp"
#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "rgbdmap/transport/transport.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"
#include "server/keyframe_fixture.hpp"

namespace rgbdmap::testing {

struct OdometrySegment {
  CameraIntrinsics camera;
  Trajectory gt;                         ///< every frame of the whole sequence, world frame
  std::vector<msg::Keyframe> keyframes;  ///< as the robot's odometry sent them (robot id "robot0")
};

/// Keyframes of the odometry over frames [first, end) of the synthetic "loop" scene with `frames` frames in
/// all, from the recorded stream (keyframe_fixture.hpp: real odometry and codec, run once at build time;
/// [first, end) is the prefix before frame `end` of the run from `first`). Cached per process.
inline const OdometrySegment& loopSegment(int frames, int first, int end) {
  static std::mutex mutex;
  static std::map<std::tuple<int, int, int>, std::unique_ptr<OdometrySegment>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto& slot = cache[{frames, first, end}];
  if (slot) return *slot;
  slot = std::make_unique<OdometrySegment>();
  EXPECT_EQ(frames, kLoopFrames) << "the recorded stream is of the " << kLoopFrames << "-frame loop";
  SynthConfig cfg;
  cfg.scene = "loop";
  cfg.frames = frames;
  auto scene = SyntheticScene::build(cfg);
  EXPECT_TRUE(scene) << scene.error();
  if (!scene) return *slot;
  slot->camera = cfg.camera;
  slot->gt = scene->trajectory();
  auto recorded = readKeyframeFixture(keyframeFixturePath(RGBDMAP_KEYFRAME_FIXTURE_DIR, first));
  EXPECT_TRUE(recorded) << recorded.error();
  if (!recorded || end < 1 || end > frames) return *slot;
  const double end_stamp = slot->gt[static_cast<size_t>(end - 1)].timestamp + 1e-6;
  for (msg::Keyframe& kf : *recorded)
    if (kf.timestamp < end_stamp) slot->keyframes.push_back(std::move(kf));
  return *slot;
}

/// Ground truth at the keyframes' stamps vs. poses given per keyframe id.
inline Result<AteResult> keyframeAte(const Trajectory& gt, const Trajectory& est) {
  return computeAte(gt, est);
}

/// A robot driven by the test: signs and publishes, records what the server sends back (acks, corrections,
/// occupancy slices, and the map stream applied to its own copy of the tree).
class ScriptedRobot {
 public:
  const std::string& id() const { return id_; }
  ScriptedRobot(transport::Transport& transport, std::string id, msg::Bytes key, int64_t session)
      : transport_(transport),
        id_(std::move(id)),
        signer_(id_, key, session),
        state_(std::make_shared<State>()) {
    msg::KeyStore keys = key.empty() ? msg::KeyStore::openMode() : msg::KeyStore();
    if (!key.empty()) {
      EXPECT_TRUE(keys.add(msg::kServerId, key));
    }
    state_->keys = std::move(keys);
    std::weak_ptr<State> weak = state_;
    auto handler = [weak](const std::string&, const uint8_t* data, size_t size) {
      auto s = weak.lock();
      if (s) s->onMessage(data, size);
    };
    for (const auto type : {msg::MessageType::kKeyframeAck, msg::MessageType::kPoseCorrections,
                            msg::MessageType::kOccupancySlice, msg::MessageType::kMapUpdate})
      EXPECT_TRUE(transport_.subscribe(*msg::channelFor(type, id_), handler));
  }

  void hello(const CameraIntrinsics& camera, const SE3& T_base_camera = defaultT_base_camera(),
             bool localize = false) {
    msg::Hello h;
    h.robot_id = id_;
    h.camera = camera;
    h.T_base_camera = T_base_camera;
    h.software_version = "test";
    if (localize) h.capabilities.push_back(msg::kCapabilityLocalize);
    publish(h);
  }
  void send(const Keyframe& kf, const EncodedImages& images, bool with_features = true) {
    auto m = keyframeToMessage(kf, id_, images, with_features);
    ASSERT_TRUE(m) << m.error();
    publish(*m);
  }
  /// A recorded keyframe message, sent as this robot's.
  void send(msg::Keyframe kf) {
    kf.robot_id = id_;
    publish(kf);
  }
  template <typename T>
  void publish(const T& message) {
    auto bytes = signer_.seal(message, 1);
    ASSERT_TRUE(bytes) << bytes.error();
    ASSERT_TRUE(transport_.publish(*msg::channelFor(T::kType, id_), *bytes));
  }
  void publishRaw(const std::string& suffix, const msg::Bytes& bytes) {
    ASSERT_TRUE(transport_.publish("rgbdmap/" + id_ + "/" + suffix, bytes));
  }
  msg::Signer& signer() { return signer_; }

  /// Waits until every id in `ids` has an ack (accepted or not).
  bool waitAcked(const std::set<int>& ids, double timeout_s) {
    std::unique_lock<std::mutex> lock(state_->mutex);
    return state_->cv.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
      for (int id : ids)
        if (!state_->acks.count(id)) return false;
      return true;
    });
  }
  std::map<int, bool> acks() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->acks;
  }
  int ackCount() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->ack_messages;
  }
  /// The latest corrections, waiting up to timeout_s for the first (delivery is asynchronous).
  std::optional<msg::PoseCorrections> corrections(double timeout_s = 10.0) const {
    std::unique_lock<std::mutex> lock(state_->mutex);
    state_->cv.wait_for(lock, std::chrono::duration<double>(timeout_s),
                        [&] { return state_->corrections.has_value(); });
    return state_->corrections;
  }
  std::optional<msg::PoseCorrections> correctionsNow() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->corrections;
  }
  int correctionMessages() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->correction_messages;
  }
  int slicesReceived() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->slices;
  }
  std::optional<msg::OccupancySlice> lastSlice() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->slice;
  }
  struct MapStreamSeen {
    int updates = 0, full = 0, partial = 0, failed = 0;
    size_t bytes = 0;
  };
  MapStreamSeen mapStream() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->stream;
  }
  /// When the ack of keyframe `id` came (the first one), if it came.
  std::optional<std::chrono::steady_clock::time_point> ackTime(int id) const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    const auto it = state_->ack_times.find(id);
    if (it == state_->ack_times.end()) return std::nullopt;
    return it->second;
  }
  /// Waits for the first MapUpdate whose tree holds keyframe `id` of this robot (robot_keyframe_id >= id)
  /// and returns when it came; nullopt on timeout.
  std::optional<std::chrono::steady_clock::time_point> waitMapWithKeyframe(int id, double timeout_s) const {
    std::unique_lock<std::mutex> lock(state_->mutex);
    const auto find = [&]() -> std::optional<std::chrono::steady_clock::time_point> {
      for (const auto& [kf, t] : state_->map_keyframes)
        if (kf >= id) return t;
      return std::nullopt;
    };
    state_->cv.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return find().has_value(); });
    return find();
  }
  /// Waits until pred(tree) holds for the robot's copy of the streamed map (checked on every update).
  bool waitMap(const std::function<bool(const octomap::OcTree&)>& pred, double timeout_s) const {
    std::unique_lock<std::mutex> lock(state_->mutex);
    return state_->cv.wait_for(lock, std::chrono::duration<double>(timeout_s),
                               [&] { return state_->map && pred(*state_->map); });
  }

 private:
  struct State {
    msg::KeyStore keys;
    msg::ReplayGuard guard;
    std::mutex mutex;
    std::condition_variable cv;
    std::map<int, bool> acks;
    std::map<int, std::chrono::steady_clock::time_point> ack_times;
    std::vector<std::pair<int, std::chrono::steady_clock::time_point>> map_keyframes;  ///< per MapUpdate
    int ack_messages = 0;
    std::optional<msg::PoseCorrections> corrections;
    int correction_messages = 0;
    int slices = 0;
    std::optional<msg::OccupancySlice> slice;
    MapStreamSeen stream;
    std::unique_ptr<octomap::OcTree> map;
    void onMessage(const uint8_t* data, size_t size) {
      auto opened = msg::openEnvelope(data, size, keys, &guard);
      if (!opened) return;
      std::lock_guard<std::mutex> lock(mutex);
      if (opened->type == msg::MessageType::kKeyframeAck) {
        if (auto ack = msg::decodeMessage<msg::KeyframeAck>(*opened)) {
          acks[ack->keyframe_id] = ack->accepted;
          ack_times.emplace(ack->keyframe_id, std::chrono::steady_clock::now());
          ++ack_messages;
        }
      } else if (opened->type == msg::MessageType::kPoseCorrections) {
        if (auto c = msg::decodeMessage<msg::PoseCorrections>(*opened)) {
          corrections = *c;
          ++correction_messages;
        }
      } else if (opened->type == msg::MessageType::kOccupancySlice) {
        if (auto sl = msg::decodeMessage<msg::OccupancySlice>(*opened)) {
          slice = std::move(*sl);
          ++slices;
        }
      } else if (opened->type == msg::MessageType::kMapUpdate) {
        if (auto u = msg::decodeMessage<msg::MapUpdate>(*opened)) {
          ++stream.updates;
          map_keyframes.emplace_back(u->robot_keyframe_id, std::chrono::steady_clock::now());
          ++(u->full ? stream.full : stream.partial);
          stream.bytes += u->data.size();
          if (!applyMapUpdate(*u, &map)) ++stream.failed;
        }
      }
      cv.notify_all();
    }
  };
  transport::Transport& transport_;
  std::string id_;
  msg::Signer signer_;
  std::shared_ptr<State> state_;
};

/// A directory of that name under the test temp dir, unique per process, removed if present and at exit.
inline std::string freshDir(const std::string& name) { return processDir("rgbdmap_server_", name); }

/// The end-to-end tests' server configuration: map in `dir`, no fsync (durability is the store's own test),
/// no status messages.
inline MapServerConfig serverTestConfig(const std::string& dir,
                                        std::vector<std::string> robots = {"robot0", "robot1"}) {
  MapServerConfig config;
  config.map_dir = dir;
  config.robots = std::move(robots);
  config.store_sync = false;
  config.status_period_s = 0.0;
  return config;
}

/// The real MapServer over memq://, knowing robot0 (testKey(1)) and robot1 (testKey(2)). A restart: stop
/// and reset `server`, then start() again.
struct ServerHarness {
  std::unique_ptr<transport::Transport> transport = std::move(transport::makeTransport("memq://").value());
  std::unique_ptr<MapServer> server;

  explicit ServerHarness(const MapServerConfig& config) {
    start(config);
    EXPECT_TRUE(transport->start());
  }
  /// The tests' default configuration (serverTestConfig) on the map directory `dir`.
  explicit ServerHarness(const std::string& dir) : ServerHarness(serverTestConfig(dir)) {}
  void start(const MapServerConfig& config) {
    msg::KeyStore keys;
    EXPECT_TRUE(keys.add("robot0", testKey(1)));
    EXPECT_TRUE(keys.add("robot1", testKey(2)));
    server = std::make_unique<MapServer>(config, *transport, std::move(keys));
    const Status s = server->start();
    EXPECT_TRUE(s) << s.error();
  }
  ~ServerHarness() {
    transport->stop();
    if (server) server->stop();
  }
};

/// Sends keyframes [from, to) of `seg` (Hello first), then waits for all their acks and for the server to
/// settle.
inline void driveRobot(MapServer& server, ScriptedRobot& robot, const OdometrySegment& seg, size_t from = 0,
                       size_t to = static_cast<size_t>(-1)) {
  robot.hello(seg.camera);
  std::set<int> ids;
  for (size_t i = from; i < std::min(to, seg.keyframes.size()); ++i) {
    robot.send(seg.keyframes[i]);
    ids.insert(seg.keyframes[i].keyframe_id);
  }
  EXPECT_TRUE(robot.waitAcked(ids, 120.0)) << "not every keyframe was acknowledged";
  EXPECT_TRUE(server.waitIdle(120.0));
}

/// Server keyframes of one robot as a trajectory (optimised, map frame).
inline Trajectory serverTrajectory(const MapServer& server, const std::string& robot) {
  Trajectory t;
  for (const ServerKeyframe& k : server.keyframes())
    if (k.robot_id == robot) t.push_back({k.timestamp, k.T_map_kf});
  return t;
}

inline Trajectory odometryTrajectory(const OdometrySegment& seg) {
  Trajectory t;
  for (const msg::Keyframe& k : seg.keyframes) t.push_back({k.timestamp, k.T_odom_cam});
  return t;
}

/// ATE RMSE of `est` against `gt` (a failed alignment fails the test and reads as 1e9 m).
inline double ateOf(const Trajectory& gt, const Trajectory& est) {
  const auto ate = computeAte(gt, est);
  EXPECT_TRUE(ate) << ate.error();
  return ate ? ate->rmse : 1e9;
}

/// Polls `done` (a test may poll; the server never does) until it holds or timeout_s passed.
inline bool eventually(const std::function<bool()>& done, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

}  // namespace rgbdmap::testing
