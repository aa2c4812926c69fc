// Fair share, end to end over memq://: a robot with a valid key flooding valid keyframes does
// not starve a well-behaved robot (per-robot queues served round-robin, a per-robot rate limit), and
// images that do not match the robot's camera are refused from their headers, before decoding.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <functional>
#include <thread>

#include <gtest/gtest.h>

#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitizedBuild = true;
#else
constexpr bool kSanitizedBuild = false;
#endif

using Clock = std::chrono::steady_clock;
using testing::eventually;
using testing::freshDir;
using testing::kLoopFrames;
using testing::loopSegment;
using testing::OdometrySegment;
using testing::ScriptedRobot;

/// A second listener on one robot's acknowledgement channel: when each keyframe was first acknowledged,
/// and with which answer.
class AckLog {
 public:
  struct Ack {
    bool accepted = false;
    std::string reason;
    Clock::time_point at;
  };

  AckLog(transport::Transport& transport, const std::string& robot, const msg::Bytes& key)
      : state_(std::make_shared<State>()) {
    EXPECT_TRUE(state_->keys.add(msg::kServerId, key));
    std::weak_ptr<State> weak = state_;
    EXPECT_TRUE(transport.subscribe(*msg::channelFor(msg::MessageType::kKeyframeAck, robot),
                                    [weak](const std::string&, const uint8_t* data, size_t size) {
                                      if (auto s = weak.lock()) s->onMessage(data, size);
                                    }));
  }
  bool waitFor(const std::set<int>& ids, double timeout_s) const {
    std::unique_lock<std::mutex> lock(state_->mutex);
    return state_->cv.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
      return std::all_of(ids.begin(), ids.end(), [&](int id) { return state_->acks.count(id) > 0; });
    });
  }
  std::map<int, Ack> acks() const {
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->acks;
  }

 private:
  struct State {
    msg::KeyStore keys;
    msg::ReplayGuard guard;
    std::mutex mutex;
    std::condition_variable cv;
    std::map<int, Ack> acks;
    void onMessage(const uint8_t* data, size_t size) {
      auto opened = msg::openEnvelope(data, size, keys, &guard);
      if (!opened) return;
      auto ack = msg::decodeMessage<msg::KeyframeAck>(*opened);
      if (!ack) return;
      std::lock_guard<std::mutex> lock(mutex);
      acks.try_emplace(ack->keyframe_id, Ack{ack->accepted, ack->reason, Clock::now()});
      cv.notify_all();
    }
  };
  std::shared_ptr<State> state_;
};

std::optional<ServerRobotStats> robotStats(const MapServer& server, const std::string& robot) {
  for (const ServerRobotStats& r : server.stats().robots)
    if (r.robot_id == robot) return r;
  return std::nullopt;
}

/// kB of a /proc/self/status field (VmRSS, VmHWM); 0 when unreadable.
long procStatusKb(const std::string& field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field + ":", 0) == 0) return std::atol(line.c_str() + field.size() + 1);
  return 0;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())))];
}

/// Sends valid keyframes of robot0 (the recorded loop, renumbered into one endless chain) as fast as it
/// can, on its own thread, until stop() or `max_keyframes` or `max_s`.
class Flood {
 public:
  Flood(ScriptedRobot& robot, const OdometrySegment& seg, int max_keyframes, double max_s)
      : thread_([this, &robot, &seg, max_keyframes, max_s] {
          robot.hello(seg.camera);
          const auto deadline = Clock::now() + std::chrono::duration<double>(max_s);
          for (int i = 0; i < max_keyframes && !stop_ && Clock::now() < deadline; ++i) {
            msg::Keyframe kf = seg.keyframes[static_cast<size_t>(i) % seg.keyframes.size()];
            kf.segment_id = 0;
            kf.keyframe_id = i;
            kf.previous_keyframe_id = i - 1;
            robot.send(std::move(kf));
            ++sent_;
          }
        }) {}
  ~Flood() { stop(); }
  int stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    return sent_.load();
  }
  int sent() const { return sent_.load(); }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<int> sent_{0};
  std::thread thread_;
};

/// Sends every keyframe of `seg` through `robot`, one each 200 ms; records when each was sent.
void sendPaced(ScriptedRobot& robot, const OdometrySegment& seg, std::map<int, Clock::time_point>* sent_at,
               std::set<int>* ids) {
  auto next = Clock::now();
  for (const msg::Keyframe& kf : seg.keyframes) {
    std::this_thread::sleep_until(next);
    next += std::chrono::milliseconds(200);
    (*sent_at)[kf.keyframe_id] = Clock::now();
    ids->insert(kf.keyframe_id);
    robot.send(kf);
  }
}

/// The flood test's measurements on one line: both robots' counts and queues, the well-behaved robot's
/// acknowledgement latencies, the process's memory, the server's ingest times.
void printFloodMeasurements(int flood_sent, const ServerRobotStats& flood, const ServerRobotStats& good,
                            double hello_s, size_t good_sent, const std::vector<double>& latency_s,
                            long rss_before_kb, const MapServerStats& s) {
  const double p50 = percentile(latency_s, 0.5), p90 = percentile(latency_s, 0.9);
  const long rss_kb = procStatusKb("VmRSS"), hwm_kb = procStatusKb("VmHWM");
  std::printf(
      "[ measured ] flood: %d keyframes sent, %d in the graph + %d waiting, %llu throttled, %llu queue full, "
      "queue max %d; "
      "well-behaved: Hello registered in %.3f s, %zu sent, %d in the graph, ack latency median %.3f s p90 "
      "%.3f s "
      "max %.3f s, queue max %d; "
      "RSS %ld -> %ld MB (peak %ld MB); ingest median %.1f ms p90 %.1f ms (verify median %.1f ms)\n",
      flood_sent, flood.keyframes, flood.keyframes_waiting, static_cast<unsigned long long>(flood.throttled),
      static_cast<unsigned long long>(flood.queue_full), flood.keyframes_queued_max, hello_s, good_sent,
      good.keyframes, p50, p90, percentile(latency_s, 1.0), good.keyframes_queued_max, rss_before_kb / 1024,
      rss_kb / 1024, hwm_kb / 1024, s.ingest_ms_median, s.ingest_ms_p90, s.verify_ms_median);
}

RGBDMAP_TEST_TIER("MapServerFair.*", "e2e");
TEST(MapServerFair, AFloodingRobotDoesNotDelayAWellBehavedOne) {
  if (kSanitizedBuild)
    GTEST_SKIP() << "a latency bound; meaningless under AddressSanitizer (runs in Release)";
  const OdometrySegment& flood_seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  const OdometrySegment& good_seg = loopSegment(kLoopFrames, 80, kLoopFrames);
  ASSERT_GT(flood_seg.keyframes.size(), 10u);
  ASSERT_GT(good_seg.keyframes.size(), 10u);
  MapServerConfig config = testing::serverTestConfig(freshDir("fair_flood"));
  config.occupancy_enabled = false;  // the map worker's queue is not bounded (README, limits)
  const long rss_before_kb = procStatusKb("VmRSS");
  testing::ServerHarness h(config);
  ScriptedRobot flooder(*h.transport, "robot0", testing::testKey(1), 100);
  ScriptedRobot good(*h.transport, "robot1", testing::testKey(2), 200);
  AckLog good_acks(*h.transport, "robot1", testing::testKey(2));
  Flood flood(flooder, flood_seg, 100000, 60.0);
  // The flood has spent its burst and fills its queue before the well-behaved robot starts.
  ASSERT_TRUE(eventually(
      [&] {
        const auto r = robotStats(*h.server, "robot0");
        return r && r->throttled > 0 && r->queue_full > 0;
      },
      30.0))
      << "the flood was neither throttled nor queue-full";
  // Its Hello does not wait behind the flood's queued keyframes.
  const auto hello_at = Clock::now();
  good.hello(good_seg.camera);
  ASSERT_TRUE(eventually([&] { return robotStats(*h.server, "robot1").has_value(); }, 10.0));
  const double hello_s = std::chrono::duration<double>(Clock::now() - hello_at).count();
  EXPECT_LT(hello_s, 1.0) << "the Hello waited behind the flood";
  // The well-behaved robot: a keyframe every 200 ms.
  std::map<int, Clock::time_point> sent_at;
  std::set<int> ids;
  sendPaced(good, good_seg, &sent_at, &ids);
  const bool all_acked = good_acks.waitFor(ids, 30.0);
  const int flood_sent = flood.stop();
  EXPECT_TRUE(all_acked) << "a keyframe of the well-behaved robot was not acknowledged";
  ASSERT_TRUE(h.server->waitIdle(120.0));

  std::vector<double> latency_s;
  for (const auto& [id, ack] : good_acks.acks()) {
    EXPECT_TRUE(ack.accepted) << "keyframe " << id << ": " << ack.reason;
    if (sent_at.count(id)) latency_s.push_back(std::chrono::duration<double>(ack.at - sent_at[id]).count());
  }
  const MapServerStats s = h.server->stats();
  const auto flood_stats = robotStats(*h.server, "robot0");
  const auto good_stats = robotStats(*h.server, "robot1");
  ASSERT_TRUE(flood_stats && good_stats);
  const double p90 = percentile(latency_s, 0.9);
  printFloodMeasurements(flood_sent, *flood_stats, *good_stats, hello_s, ids.size(), latency_s, rss_before_kb,
                         s);

  EXPECT_EQ(latency_s.size(), ids.size());
  EXPECT_LT(p90, 1.0) << "the well-behaved robot's acknowledgements are late";
  EXPECT_EQ(good_stats->keyframes, static_cast<int>(ids.size())) << "not every keyframe is in the graph";
  EXPECT_EQ(good_stats->throttled, 0u);
  EXPECT_EQ(good_stats->queue_full, 0u);
  EXPECT_EQ(good_stats->keyframes_refused, 0u);
  // The flood's excess was counted, its queue stayed within its bound, the rest went through.
  EXPECT_GT(flood_stats->throttled, 0u);
  EXPECT_GT(flood_stats->queue_full, 0u);
  EXPECT_GT(flood_stats->keyframes, 0);
  EXPECT_LE(flood_stats->keyframes_queued_max, static_cast<int>(config.robot_queue_capacity));
  EXPECT_LE(good_stats->keyframes_queued_max, static_cast<int>(config.robot_queue_capacity));
  EXPECT_EQ(s.inbox.keyframes_throttled, flood_stats->throttled);
  EXPECT_EQ(s.inbox.keyframes_dropped_queue_full, flood_stats->queue_full);
  EXPECT_LE(static_cast<uint64_t>(flood_stats->keyframes) + flood_stats->throttled + flood_stats->queue_full,
            static_cast<uint64_t>(flood_sent));
}

/// The robot's link after an outage: every unacknowledged keyframe is resent each retransmission round
/// (the ReliableSender's backoff tops out at 2 s). With the default queue, burst and rate, a whole window
/// gets through in far fewer rounds than the client's max_attempts (20).
TEST(MapServerFair, ARecoveryBurstGetsThroughTheDefaultLimitsInAFewRounds) {
  if (kSanitizedBuild)
    GTEST_SKIP() << "a latency bound; meaningless under AddressSanitizer (runs in Release)";
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GT(seg.keyframes.size(), 10u);
  MapServerConfig config = testing::serverTestConfig(freshDir("fair_recovery"));
  config.occupancy_enabled = false;
  testing::ServerHarness h(config);
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  AckLog acks(*h.transport, "robot0", testing::testKey(1));
  robot.hello(seg.camera);
  ASSERT_TRUE(eventually([&] { return robotStats(*h.server, "robot0").has_value(); }, 10.0));
  const int window = 160;  // keyframes unacknowledged when the link comes back
  std::set<int> pending;
  for (int i = 0; i < window; ++i) pending.insert(i);
  const auto t0 = Clock::now();
  int rounds = 0;
  for (; rounds < 20 && !pending.empty(); ++rounds) {
    for (const int i : pending) {
      msg::Keyframe kf = seg.keyframes[static_cast<size_t>(i) % seg.keyframes.size()];
      kf.segment_id = 0;
      kf.keyframe_id = i;
      kf.previous_keyframe_id = i - 1;
      robot.send(std::move(kf));
    }
    (void)acks.waitFor(pending, 2.0);
    for (const auto& [id, ack] : acks.acks()) pending.erase(id);
  }
  const double took_s = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto r = robotStats(*h.server, "robot0");
  ASSERT_TRUE(r);
  std::printf(
      "[ measured ] recovery of %d keyframes: %d rounds, %.1f s, %llu throttled, %llu queue full, %d "
      "stored\n",
      window, rounds, took_s, static_cast<unsigned long long>(r->throttled),
      static_cast<unsigned long long>(r->queue_full), r->keyframes);
  EXPECT_TRUE(pending.empty()) << pending.size() << " keyframes never acknowledged";
  EXPECT_LE(rounds, 12) << "too close to the client's max_attempts";
}

/// A robot whose acknowledgements are late resends every keyframe still unacknowledged, again and again.
/// Copies of a keyframe that is still queued take no slot: its queue does not fill with them, it is not
/// demoted for the server's delay (the fleet run lost two robots to that spiral), every keyframe goes in
/// once.
TEST(MapServerFair, ResendsOfQueuedKeyframesDoNotFillTheRobotsQueue) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GT(seg.keyframes.size(), 10u);
  MapServerConfig config = testing::serverTestConfig(freshDir("fair_resend"));
  config.occupancy_enabled = false;
  config.robot_queue_capacity = 16;
  testing::ServerHarness h(config);
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  AckLog acks(*h.transport, "robot0", testing::testKey(1));
  robot.hello(seg.camera);
  ASSERT_TRUE(eventually([&] { return robotStats(*h.server, "robot0").has_value(); }, 10.0));
  const int n = 12, copies = 8;  // 96 messages within the burst (256): none throttled
  std::set<int> ids;
  for (int c = 0; c < copies; ++c)
    for (int i = 0; i < n; ++i) {
      msg::Keyframe kf = seg.keyframes[static_cast<size_t>(i) % seg.keyframes.size()];
      kf.segment_id = 0;
      kf.keyframe_id = i;
      kf.previous_keyframe_id = i - 1;
      robot.send(std::move(kf));
      ids.insert(i);
    }
  EXPECT_TRUE(acks.waitFor(ids, 60.0)) << "not every keyframe was acknowledged";
  ASSERT_TRUE(h.server->waitIdle(120.0));
  const auto r = robotStats(*h.server, "robot0");
  ASSERT_TRUE(r);
  std::printf(
      "[ measured ] %d keyframes x %d copies: %llu queued copies dropped, %llu answered as stored, "
      "%llu queue full, queue max %d\n",
      n, copies, static_cast<unsigned long long>(r->duplicates_queued),
      static_cast<unsigned long long>(r->duplicates), static_cast<unsigned long long>(r->queue_full),
      r->keyframes_queued_max);
  EXPECT_EQ(r->queue_full, 0u) << "copies of queued keyframes filled the queue";
  EXPECT_EQ(r->throttled, 0u);
  EXPECT_GT(r->duplicates_queued, 0u) << "no copy met its original in the queue";
  EXPECT_EQ(r->duplicates_queued + r->duplicates, static_cast<uint64_t>(n * (copies - 1)));
  EXPECT_LE(r->keyframes_queued_max, n);
  EXPECT_EQ(r->keyframes, n);
  EXPECT_EQ(h.server->stats().inbox.keyframes_duplicates_queued, r->duplicates_queued);
}

RGBDMAP_TEST_TIER("MapServerFair.ImagesThatDoNotMatchTheCameraAreRefusedBeforeDecoding", "e2e sanitize");
TEST(MapServerFair, ImagesThatDoNotMatchTheCameraAreRefusedBeforeDecoding) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, 60);
  ASSERT_GE(seg.keyframes.size(), 3u);
  MapServerConfig config = testing::serverTestConfig(freshDir("fair_images"));
  config.occupancy_enabled = false;
  testing::ServerHarness h(config);
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  AckLog acks(*h.transport, "robot0", testing::testKey(1));
  testing::driveRobot(*h.server, robot, seg, 0, 1);
  ASSERT_EQ(h.server->stats().keyframes_decoded, 1u);
  // 4096 x 4096 constant images: ~100 KB on the wire, 84 MB decoded. The camera said 640 x 480.
  RgbdFrame frame;
  frame.depth = cv::Mat(4096, 4096, CV_16UC1, cv::Scalar(5000));
  frame.color = cv::Mat(4096, 4096, CV_8UC3, cv::Scalar(90, 110, 130));
  auto big_images = encodeImages(frame);
  ASSERT_TRUE(big_images) << big_images.error();
  frame = RgbdFrame();
  msg::Keyframe big = seg.keyframes[1];
  big.images = *big_images;
  std::printf("[ measured ] 4096x4096 constant keyframe: %zu bytes of images\n",
              big.images.depth.size() + big.images.color.size());
  robot.send(big);
  ASSERT_TRUE(acks.waitFor({big.keyframe_id}, 30.0));
  const AckLog::Ack refused = acks.acks().at(big.keyframe_id);
  EXPECT_FALSE(refused.accepted);
  EXPECT_NE(refused.reason.find("differs from the camera"), std::string::npos) << refused.reason;
  // A robot that announces a 4096 x 4096 camera: over server.max_image_pixels.
  ScriptedRobot giant(*h.transport, "robot1", testing::testKey(2), 200);
  AckLog giant_acks(*h.transport, "robot1", testing::testKey(2));
  CameraIntrinsics giant_camera = seg.camera;
  giant_camera.width = giant_camera.height = 4096;
  giant.hello(giant_camera);
  ASSERT_TRUE(eventually([&] { return robotStats(*h.server, "robot1").has_value(); }, 10.0));
  giant.send(big);
  ASSERT_TRUE(giant_acks.waitFor({big.keyframe_id}, 30.0));
  const AckLog::Ack too_big = giant_acks.acks().at(big.keyframe_id);
  EXPECT_FALSE(too_big.accepted);
  EXPECT_NE(too_big.reason.find("above server.max_image_pixels"), std::string::npos) << too_big.reason;
  // Neither was decoded; both are counted; the robot's next keyframe goes through.
  testing::driveRobot(*h.server, robot, seg, 2, 3);
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes_decoded, 2u) << "a refused keyframe's images were decoded";
  EXPECT_EQ(s.keyframes_refused, 2u);
  EXPECT_EQ(s.keyframes, 2);
  EXPECT_EQ(robotStats(*h.server, "robot0")->refused_before_decode, 1u);
  EXPECT_EQ(robotStats(*h.server, "robot1")->refused_before_decode, 1u);
}

}  // namespace
}  // namespace rgbdmap
