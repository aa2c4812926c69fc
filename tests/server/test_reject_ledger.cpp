// Rejected messages named by their claimed sender ("clear failure"): the rate-limited log line per
// claimed id, the bounded tables hostile senders cannot grow, and end to end a robot with a wrong key showing
// up as bad signatures of that robot in the server's stats and in the ServerStatus it publishes.
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "../../server/core/src/reject_ledger.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "server/server_test_util.hpp"

namespace rgbdmap {
namespace {

using Clock = RejectLedger::Clock;
using std::chrono::seconds;

int64_t countOf(const std::vector<msg::RejectCount>& counts, const std::string& robot,
                const std::string& reason) {
  for (const msg::RejectCount& c : counts)
    if (c.robot_id == robot && c.reason == reason) return c.count;
  return 0;
}

RejectLedger knowing(std::vector<std::string> robots, RejectLedgerOptions options = {}) {
  return RejectLedger(options, [robots](const std::string& id) {
    return std::find(robots.begin(), robots.end(), id) != robots.end();
  });
}

TEST(RejectLedger, NamesTheClaimedSenderAtMostOncePerIntervalWithTheSuppressedCount) {
  RejectLedger ledger = knowing({"robot1"});
  const Clock::time_point t0 = Clock::now();
  const std::string first = ledger.add("robot1", "bad_signature", "", t0);
  EXPECT_NE(first.find("claiming to be from 'robot1': bad signature"), std::string::npos) << first;
  EXPECT_NE(first.find("1 bad_signature from robot1 so far"), std::string::npos) << first;
  for (int i = 1; i <= 9; ++i) EXPECT_EQ(ledger.add("robot1", "bad_signature", "", t0 + seconds(i)), "");
  EXPECT_NE(ledger.add("robot2", "bad_signature", "", t0 + seconds(1)), "")
      << "another claimed id has its own limit";
  const std::string next = ledger.add("robot1", "bad_signature", "", t0 + seconds(10));
  EXPECT_NE(next.find("11 bad_signature from robot1 so far"), std::string::npos) << next;
  EXPECT_NE(next.find("9 from this sender not logged since its last line"), std::string::npos) << next;
  EXPECT_EQ(countOf(ledger.counts(), "robot1", "bad_signature"), 11);
  EXPECT_EQ(countOf(ledger.counts(), "", "bad_signature"), 1) << "robot2 is not known: the unknown bucket";
}

TEST(RejectLedger, ClaimedIdsAreSanitisedForTheLog) {
  EXPECT_EQ(RejectLedger::sanitize("robot_1"), "robot_1");
  EXPECT_EQ(RejectLedger::sanitize(std::string("a\nb\x1b[31m'\xff", 10)), "a?b?[31m??");
  EXPECT_EQ(RejectLedger::sanitize(std::string(100, 'x')), std::string(msg::kMaxIdLength, 'x') + "...");
  RejectLedger ledger = knowing({});
  const std::string line =
      ledger.add(std::string("evil\n[fake] server: all good") + std::string(200, 'z'), "invalid_sender");
  EXPECT_EQ(line.find('\n'), std::string::npos) << line;
  EXPECT_LT(line.size(), 300u) << line;
  EXPECT_EQ(RejectLedger::reasonKey(msg::RejectReason::kBadSignature), "bad_signature");
  EXPECT_EQ(RejectLedger::reasonKeyOf("header mismatch"), "header_mismatch");
  EXPECT_EQ(RejectLedger::reasonKeyOf("invalid content: too many keypoints"), "invalid_content");
}

TEST(RejectLedger, HostileClaimedIdsCannotGrowTheTables) {
  RejectLedgerOptions options;
  options.max_claimed_ids = 64;
  RejectLedger ledger = knowing({"robot0"}, options);
  const Clock::time_point t0 = Clock::now();
  int lines = 0;
  for (int i = 0; i < 100000; ++i)
    lines +=
        !ledger.add("fake" + std::to_string(i), i % 2 ? "bad_signature" : "unknown_sender", "", t0).empty();
  EXPECT_NE(ledger.add("robot0", "replayed_seq", "", t0), "") << "a known robot is still counted on its own";
  EXPECT_EQ(ledger.trackedClaimedIds(), 65u)
      << "64 invented ids and the known robot0 (the rest share 'other')";
  EXPECT_EQ(lines, 1) << "lines about unknown claimed ids: at most unknown_lines_per_s overall";
  const std::vector<msg::RejectCount> counts = ledger.counts();
  EXPECT_EQ(countOf(counts, "", "bad_signature") + countOf(counts, "", "unknown_sender"), 100000);
  EXPECT_EQ(countOf(counts, "robot0", "replayed_seq"), 1);
  EXPECT_EQ(counts.size(), 3u) << "unknown claimed ids share one bucket per reason";
  const std::string other = ledger.add("fake999999", "bad_signature", "", t0 + seconds(11));
  EXPECT_NE(other.find("beyond the first 64"), std::string::npos) << other;
}

TEST(RejectLedger, KnownRobotsWithOwnCountersAreBoundedToo) {
  RejectLedgerOptions options;
  options.max_known = 2;
  RejectLedger ledger(options, [](const std::string&) { return true; });
  for (const char* id : {"a", "b", "c", "d"}) ledger.add(id, "malformed");
  ledger.add("a", "malformed");
  const std::vector<msg::RejectCount> counts = ledger.counts();
  EXPECT_EQ(countOf(counts, "a", "malformed"), 2);
  EXPECT_EQ(countOf(counts, "b", "malformed"), 1);
  EXPECT_EQ(countOf(counts, "", "malformed"), 2) << "c and d";
  EXPECT_EQ(counts.front().count, 2) << "largest first";
  EXPECT_EQ(ledger.counts(1).size(), 1u);
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
  while (s.messages_rejected < 5 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    s = h.server->stats();
  }
  ASSERT_TRUE(h.server->waitIdle(30.0));
  EXPECT_EQ(countOf(s.rejects, "robot1", "bad_signature"), 3) << "hello and two keyframes";
  EXPECT_EQ(countOf(s.rejects, "robot1", "truncated"), 1);
  EXPECT_EQ(countOf(s.rejects, "", "unknown_sender"), 1) << "robot7 is not a known robot";
  EXPECT_EQ(s.keyframes, 0);
  EXPECT_TRUE(wrong.acks().empty());
  // The status reaches robot1's channel although robot1 never said Hello (so it, or a monitor, can tell).
  const auto status = listener.waitFor(
      [](const msg::ServerStatus& st) { return countOf(st.rejects, "robot1", "bad_signature") >= 3; });
  ASSERT_TRUE(status);
  EXPECT_EQ(countOf(status->rejects, "robot1", "bad_signature"), 3);
  EXPECT_TRUE(status->robots.empty()) << "robot1 is not a registered robot";
}

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
  while (s.messages_rejected < static_cast<uint64_t>(kMessages) &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    s = h.server->stats();
  }
  EXPECT_EQ(s.messages_rejected, static_cast<uint64_t>(kMessages));
  EXPECT_EQ(s.keyframes, 0);
  EXPECT_TRUE(s.robots.empty()) << "no forged Hello registered anything";
  int64_t total = 0;
  for (const msg::RejectCount& r : s.rejects) {
    total += r.count;
    EXPECT_TRUE(r.robot_id.empty() || r.robot_id == "robot0" || r.robot_id == "robot1") << r.robot_id;
  }
  EXPECT_EQ(total, kMessages);
  EXPECT_LE(s.rejects.size(), 3u * static_cast<size_t>(msg::RejectReason::kCount))
      << "robot0, robot1, unknown";
  EXPECT_EQ(countOf(s.rejects, "", "unknown_sender"), (kMessages + 2) / 3);
}

}  // namespace
}  // namespace rgbdmap
