// Rejected messages end to end: a robot with a wrong key shows up as bad signatures of that robot in the
// server's stats and in the ServerStatus it publishes; forged messages are counted in bounded buckets.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "rgbdmap/proto/channels.hpp"
#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using std::chrono::seconds;

int64_t countOf(const std::vector<msg::RejectCount>& counts, const std::string& robot,
                const std::string& reason) {
  for (const msg::RejectCount& c : counts)
    if (c.robot_id == robot && c.reason == reason) return c.count;
  return 0;
}

/// The ServerStatus copies the server sends on robot1's channel, read with the server's key for robot1.
class StatusListener {
 public:
  StatusListener(transport::Transport& transport, const std::string& robot, const msg::Bytes& key) {
    EXPECT_TRUE(keys_.add(msg::kServerId, key));
    EXPECT_TRUE(transport.subscribe(*msg::channelFor(msg::MessageType::kServerStatus, robot),
                                    [this](const std::string&, const uint8_t* data, size_t size) {
                                      auto opened = msg::openEnvelope(data, size, keys_, nullptr);
                                      if (!opened) return;
                                      auto status = msg::decodeMessage<msg::ServerStatus>(*opened);
                                      if (!status) return;
                                      std::lock_guard<std::mutex> lock(mutex_);
                                      latest_ = *status;
                                      cv_.notify_all();
                                    }));
  }
  std::optional<msg::ServerStatus> waitFor(const std::function<bool(const msg::ServerStatus&)>& done) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait_for(lock, seconds(20), [&] { return latest_ && done(*latest_); });
    return latest_;
  }

 private:
  msg::KeyStore keys_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<msg::ServerStatus> latest_;
};

RGBDMAP_TEST_TIER("MapServer.ARobotWithAWrongKeyIsCountedAsBadSignaturesOfThatRobotInStatsAndStatus",
                  "e2e sanitize");
TEST(MapServer, ARobotWithAWrongKeyIsCountedAsBadSignaturesOfThatRobotInStatsAndStatus) {
  const testing::OdometrySegment& seg = testing::loopSegment(testing::kLoopFrames, 0, 30);
  ASSERT_GE(seg.keyframes.size(), 2u);
  MapServerConfig config = testing::serverTestConfig(testing::freshDir("wrong_key"));
  config.status_period_s = 0.05;
  testing::ServerHarness h(config);
  StatusListener listener(*h.transport, "robot1", rgbdmap::testing::testKey(2));
  // robot1 signs with robot0's key; the server holds testKey(2) for robot1.
  testing::ScriptedRobot wrong(*h.transport, "robot1", rgbdmap::testing::testKey(1), 100);
  wrong.hello(seg.camera);
  wrong.send(seg.keyframes[0]);
  wrong.send(seg.keyframes[1]);
  // Garbage on robot1's channel is robot1's (the channel is all it claims); a signed message from a sender
  // the server has no key for goes to the unknown bucket.
  wrong.publishRaw("keyframe", msg::Bytes(64, 0x11));
  msg::Signer stranger("robot7", rgbdmap::testing::testKey(7));
  msg::Keyframe strange = seg.keyframes[0];
  strange.robot_id = "robot7";
  const auto sealed = stranger.seal(strange, 1);
  ASSERT_TRUE(sealed);
  ASSERT_TRUE(h.transport->publish("rgbdmap/robot1/keyframe", *sealed));
  // memq:// delivers on its own thread: wait until the five rejections are counted.
  const auto deadline = std::chrono::steady_clock::now() + seconds(20);
  MapServerStats s = h.server->stats();
  while (s.inbox.messages_rejected < 5 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    s = h.server->stats();
  }
  ASSERT_TRUE(h.server->waitIdle(30.0));
  EXPECT_EQ(countOf(s.inbox.rejects, "robot1", "bad_signature"), 3) << "hello and two keyframes";
  EXPECT_EQ(countOf(s.inbox.rejects, "robot1", "truncated"), 1);
  EXPECT_EQ(countOf(s.inbox.rejects, "", "unknown_sender"), 1) << "robot7 is not a known robot";
  EXPECT_EQ(s.keyframes, 0);
  EXPECT_TRUE(wrong.acks().empty());
  // The status reaches robot1's channel although robot1 never said Hello (so it, or a monitor, can tell).
  const auto status = listener.waitFor(
      [](const msg::ServerStatus& st) { return countOf(st.rejects, "robot1", "bad_signature") >= 3; });
  ASSERT_TRUE(status);
  EXPECT_EQ(countOf(status->rejects, "robot1", "bad_signature"), 3);
  EXPECT_TRUE(status->robots.empty()) << "robot1 is not a registered robot";
}

RGBDMAP_TEST_TIER("MapServer.HundredThousandForgedMessagesAreCountedInBoundedBucketsAndNeverAccepted",
                  "e2e sanitize");
TEST(MapServer, HundredThousandForgedMessagesAreCountedInBoundedBucketsAndNeverAccepted) {
  MapServerConfig config = testing::serverTestConfig(testing::freshDir("forged"));
  testing::ServerHarness h(config);
  std::mt19937 rng(11);
  constexpr int kMessages = 100000;
  for (int i = 0; i < kMessages; ++i) {
    msg::Bytes bytes;
    if (i % 3 == 2) {
      bytes.resize(16 + rng() % 200);
      for (uint8_t& b : bytes) b = static_cast<uint8_t>(rng());
    } else {  // an invented sender id (no key), or robot0 with a wrong key
      msg::Heartbeat hb;
      hb.robot_id = i % 3 == 0 ? "fake" + std::to_string(i) : "robot0";
      msg::Signer signer(hb.robot_id, rgbdmap::testing::testKey(100 + static_cast<int>(rng() % 50)));
      bytes = signer.seal(hb, 1).value();
    }
    ASSERT_TRUE(h.transport->publish(i % 2 ? "rgbdmap/robot0/heartbeat" : "rgbdmap/robot1/keyframe", bytes));
  }
  const auto deadline = std::chrono::steady_clock::now() + seconds(120);
  MapServerStats s = h.server->stats();
  while (s.inbox.messages_rejected < static_cast<uint64_t>(kMessages) &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    s = h.server->stats();
  }
  EXPECT_EQ(s.inbox.messages_rejected, static_cast<uint64_t>(kMessages));
  EXPECT_EQ(s.keyframes, 0);
  EXPECT_TRUE(s.robots.empty()) << "no forged Hello registered anything";
  int64_t total = 0;
  for (const msg::RejectCount& r : s.inbox.rejects) {
    total += r.count;
    EXPECT_TRUE(r.robot_id.empty() || r.robot_id == "robot0" || r.robot_id == "robot1") << r.robot_id;
  }
  EXPECT_EQ(total, kMessages);
  EXPECT_LE(s.inbox.rejects.size(), 3u * static_cast<size_t>(msg::RejectReason::kCount))
      << "robot0, robot1, unknown";
  EXPECT_EQ(countOf(s.inbox.rejects, "", "unknown_sender"), (kMessages + 2) / 3);
}

}  // namespace
}  // namespace rgbdmap
