// RobotLink with a keyframe spool, over memq:// against the fake server: a server that is not there does
// not block the robot, and its keyframes arrive once it is; a robot that ends with unanswered keyframes
// hands them to its next start, which delivers them once each, in the same session, above them its own.
#include <gtest/gtest.h>

#include <filesystem>

#include "fake_map_server.hpp"
#include "link_test_util.hpp"
#include "rgbdmap/link/delivery_report.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;
using testing::FakeMapServer;
using testing::linkKey;
using testing::linkOptions;
using testing::serverOptions;
using testing::smallFrame;
using testing::smallKeyframe;
using testing::testPose;

std::string linkSpoolDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("link_spool_" + name);
  fs::remove_all(dir);
  return dir.string();
}

RobotLinkOptions spooledOptions(const std::string& dir) {
  RobotLinkOptions o = linkOptions("robot0", linkKey(1));
  auto spool = KeyframeSpool::open({dir, uint64_t{1} << 30}, "robot0");
  EXPECT_TRUE(spool.ok()) << spool.error();
  if (spool) o.spool = std::move(*spool);
  o.reliable.max_pending = 2;
  o.send_timeout_s = 0.05;  // without a spool the third keyframe would be skipped after 50 ms
  return o;
}

void sendRange(RobotLink& link, int first, int count, int segment) {
  for (int id = first; id < first + count; ++id)
    ASSERT_TRUE(link.sendKeyframe(smallKeyframe(id, segment, testPose(id), id > first ? id - 1 : -1),
                                  smallFrame(id)));
}

TEST(RobotLinkSpool, NoServerBlocksNothingAndEverythingArrivesWhenItComes) {
  std::mutex m;                         // declared before the transport, whose handler uses them
  std::optional<msg::LinkStatus> seen;  // what the monitor reads: the robot's LinkStatus
  msg::KeyStore keys;
  ASSERT_TRUE(keys.add("robot0", linkKey(1)));
  msg::ReplayGuard guard;
  msg::RejectCounters rejects;
  auto transport = testing::makeMemq();
  const std::string dir = linkSpoolDir("outage");
  RobotLinkOptions o = spooledOptions(dir);
  RobotLink link(*transport, o);
  ASSERT_TRUE(link.start());
  ASSERT_TRUE(
      transport->subscribe("rgbdmap/robot0/link", [&](const std::string&, const uint8_t* d, size_t n) {
        auto opened = msg::openEnvelope(d, n, keys, &guard, &rejects);
        auto status = opened ? msg::decodeMessage<msg::LinkStatus>(*opened, &rejects)
                             : Result<msg::LinkStatus>::failure("");
        std::lock_guard<std::mutex> lock(m);
        if (status) seen = *status;
      }));
  sendRange(link, 0, 12, 0);  // 12 keyframes, a window of 2, no server: all spooled, none skipped
  RobotLinkStats st = link.stats();
  EXPECT_EQ(st.keyframes_spooled, 12u);
  EXPECT_EQ(st.spool_depth, 12u);
  EXPECT_GE(st.keyframes_queued, 10u);
  EXPECT_FALSE(link.waitAllAcked(0.3));  // also a few heartbeat periods: LinkStatus published
  {
    std::lock_guard<std::mutex> lock(m);
    ASSERT_TRUE(seen.has_value());
    EXPECT_EQ(seen->spool_depth, 12);
    EXPECT_EQ(seen->keyframes_made, 12);
    EXPECT_EQ(seen->keyframes_acked, 0);
    EXPECT_EQ(seen->in_flight + seen->queued, 12);
    EXPECT_GT(seen->oldest_unanswered_s, 0.0);
    EXPECT_GT(seen->spool_bytes, 0);
    EXPECT_FALSE(seen->live_only);
  }
  FakeMapServer server(*transport, serverOptions(linkKey(1)));
  server.start();
  ASSERT_TRUE(link.waitAllAcked(20.0));
  st = link.stats();
  EXPECT_EQ(st.keyframes_acked, 12u);
  EXPECT_EQ(st.spool_depth, 0u);
  EXPECT_EQ(st.keyframes_pending, 0u);
  std::lock_guard<std::mutex> lock(server.state().mutex);
  EXPECT_EQ(server.state().stored.size(), 12u);
}

TEST(RobotLinkSpool, TheNextStartDeliversWhatWasLeftOnceEachInTheSameSession) {
  auto transport = testing::makeMemq();
  const std::string dir = linkSpoolDir("restart");
  int64_t first_session = 0;
  {
    RobotLinkOptions o = spooledOptions(dir);
    first_session = o.spool->session();
    RobotLink link(*transport, o);
    ASSERT_TRUE(link.start());
    sendRange(link, 0, 6, 0);
    link.stop();  // the robot ends (or is killed) with no server heard: the spool keeps all six
  }
  FakeMapServer server(*transport, serverOptions(linkKey(1)));
  server.start();
  RobotLinkOptions o = spooledOptions(dir);
  ASSERT_TRUE(o.spool->resumed());
  EXPECT_EQ(o.spool->session(), first_session);
  const int first_id = o.spool->firstKeyframeId(), first_segment = o.spool->firstSegment();
  EXPECT_GE(first_id, 6);
  EXPECT_GE(first_segment, 1);
  RobotLink link(*transport, o);
  ASSERT_TRUE(link.start());
  sendRange(link, first_id, 3, first_segment);
  ASSERT_TRUE(link.waitAllAcked(20.0));
  const RobotLinkStats st = link.stats();
  EXPECT_EQ(st.spool_recovered, 6u);
  EXPECT_EQ(st.recovered_acked, 6u);
  EXPECT_EQ(st.keyframes_acked, 9u);
  EXPECT_EQ(st.spool_depth, 0u);
  EXPECT_EQ(st.messages_rejected, 0u);
  EXPECT_EQ(server.rejects().total(), 0u) << "the resumed session's seq passes the server's replay guard";
  std::lock_guard<std::mutex> lock(server.state().mutex);
  ASSERT_EQ(server.state().stored.size(), 9u);
  for (const auto& [id, kf] : server.state().stored) {
    EXPECT_EQ(kf.header.session, first_session) << id;
    EXPECT_EQ(server.state().receptions.at(id), 1) << "keyframe " << id << " stored once";
    EXPECT_EQ(kf.segment_id, id < 6 ? 0 : first_segment);
  }
}

// The report: keyframes left spooled are not lost (exit 0 for rgbdmap-client), refused ones are.
TEST(RobotLinkSpool, SpooledKeyframesAreNotCountedAsLost) {
  RobotRunResult r;
  r.keyframes = 10;
  r.link.keyframes_acked = 6;
  r.link.spool_depth = 4;
  DeliveryReport d = deliveryReport(r, "robot0");
  EXPECT_EQ(d.unaccepted, 4);
  EXPECT_EQ(d.spooled, 4);
  EXPECT_EQ(d.lost, 0);
  r.link.keyframes_refused = 1;
  r.link.spool_depth = 3;
  d = deliveryReport(r, "robot0");
  EXPECT_EQ(d.lost, 1);
  EXPECT_NE(d.message.find("3 keyframes are in the spool"), std::string::npos) << d.message;
  // Two left by an earlier run, one of them acknowledged now: this run's 10 - 6 are still spooled.
  r.link.keyframes_refused = 0;
  r.link.spool_recovered = 2;
  r.link.recovered_acked = 1;
  r.link.keyframes_acked = 7;
  r.link.spool_depth = 5;
  d = deliveryReport(r, "robot0");
  EXPECT_EQ(d.unaccepted, 4);
  EXPECT_EQ(d.lost, 0);
}

}  // namespace
}  // namespace rgbdmap
