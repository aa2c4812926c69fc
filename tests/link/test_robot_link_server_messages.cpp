// RobotLink and what the server sends it: its own counters from the server status, corrections, slices and
// commands, rejected garbage, forgeries, replays and misaddressed messages, wrong keys in both directions.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <future>
#include <thread>

#include "fake_map_server.hpp"
#include "link_test_util.hpp"
#include "rgbdmap/link/delivery_report.hpp"
#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap {
namespace {

using testing::FakeMapServer;
using testing::FakeServerOptions;
using testing::linkKey;
using testing::linkOptions;
using testing::sendKeyframes;
using testing::serverOptions;
using testing::smallFrame;
using testing::smallKeyframe;
using testing::testPose;

/// Sealed bytes (a failure is a test failure, never a dereferenced empty result).
template <typename T>
msg::Bytes sealOrFail(msg::Signer& signer, const T& message) {
  Result<msg::Bytes> bytes = signer.seal(message, 1);
  EXPECT_TRUE(bytes) << bytes.error();
  return bytes ? *bytes : msg::Bytes{};
}

msg::Bytes statusWithBadSignatures(const std::string& robot, int64_t bad, const msg::Bytes& key) {
  msg::ServerStatus status;
  status.rejects = {{robot, "bad_signature", bad}, {"", "unknown_sender", 99}};
  msg::Signer server(msg::kServerId, key);
  return sealOrFail(server, status);
}

/// The link's stats once `done` holds for them (memq:// delivers on its own thread), or after 5 s.
RobotLinkStats statsWhen(const RobotLink& link, const std::function<bool(const RobotLinkStats&)>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  RobotLinkStats st = link.stats();
  while (!done(st) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    st = link.stats();
  }
  return st;
}

TEST(RobotLink, ReadsItsOwnCountersFromTheServerStatusVerifiedOrNot) {
  auto transport = testing::makeMemq();
  RobotLink link(*transport, linkOptions("robot0", linkKey(5)));
  ASSERT_TRUE(link.start());
  const std::string channel = *msg::channelFor(msg::MessageType::kServerStatus, "robot0");
  // Signed with another key than the robot's: read as an unverified hint only.
  ASSERT_TRUE(transport->publish(channel, statusWithBadSignatures("robot0", 12, linkKey(6))));
  RobotLinkStats st = statsWhen(link, [](const RobotLinkStats& s) { return s.server_status_seen; });
  EXPECT_FALSE(st.server_rejects_verified);
  EXPECT_EQ(st.server_rejects, (std::map<std::string, int64_t>{{"bad_signature", 12}}));
  EXPECT_EQ(st.bad_signatures, 1u);
  EXPECT_FALSE(st.server_heard) << "an unverified status is not a server heard";
  EXPECT_FALSE(link.latestServerStatus().has_value()) << "nor acted on";
  // A verified one replaces it, and an unverified one never overrides a verified one.
  ASSERT_TRUE(transport->publish(channel, statusWithBadSignatures("robot0", 3, linkKey(5))));
  st = statsWhen(link, [](const RobotLinkStats& s) { return s.server_rejects_verified; });
  EXPECT_EQ(st.server_rejects, (std::map<std::string, int64_t>{{"bad_signature", 3}}));
  ASSERT_TRUE(transport->publish(channel, statusWithBadSignatures("robot0", 50, linkKey(6))));
  st = statsWhen(link, [](const RobotLinkStats& s) { return s.bad_signatures >= 2; });
  EXPECT_EQ(st.bad_signatures, 2u);
  EXPECT_TRUE(st.server_rejects_verified);
  EXPECT_EQ(st.server_rejects, (std::map<std::string, int64_t>{{"bad_signature", 3}}));
  link.stop();
}

TEST(RobotLink, AnUnsignedNotServedNoticeWordsTheDiagnosisAndNothingElse) {
  auto transport = testing::makeMemq();
  RobotLink link(*transport, linkOptions("robot2", linkKey(5)));
  ASSERT_TRUE(link.start());
  EXPECT_EQ(link.stats().diagnosis, "") << "no verdict before 3 s";
  msg::ServerStatus notice;  // what the server's RefusalNotices sends: unsigned, no robots
  notice.state = "not serving robot2";
  notice.rejects = {{"robot2", "unknown_robot", 4}};
  msg::Signer unsigned_server(msg::kServerId, msg::Bytes{});
  ASSERT_TRUE(transport->publish(*msg::channelFor(msg::MessageType::kServerStatus, "robot2"),
                                 sealOrFail(unsigned_server, notice)));
  RobotLinkStats st = statsWhen(link, [](const RobotLinkStats& s) { return s.diagnosis != ""; });
  EXPECT_EQ(st.not_served_notices, 1u);
  EXPECT_EQ(st.bad_signatures, 0u) << "a notice is not a server with another key";
  EXPECT_FALSE(st.server_heard);
  EXPECT_FALSE(st.server_rejects_verified);
  EXPECT_EQ(st.diagnosis, "not served by the server");
  EXPECT_EQ(notServedReason(st), "it is not in the server's robot list");
  link.stop();
  RobotRunResult run;
  run.keyframes = 3;
  run.link = st;
  EXPECT_NE(deliveryReport(run, "robot2").message.find(
                "3 of 3 keyframes not accepted: the server does not serve robot id 'robot2': it is not in the "
                "server's robot list (its unsigned notice, not verifiable here)"),
            std::string::npos)
      << deliveryReport(run, "robot2").message;
}

TEST(RobotLink, CorrectionsMoveEachSegmentIntoTheMap) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions(linkKey(4));
  so.T_map_odom = {{0, testPose(7)}, {1, testPose(-3)}};
  FakeMapServer server(*transport, so);
  server.start();
  RobotLink link(*transport, linkOptions("robot0", linkKey(4)));
  ASSERT_TRUE(link.start());
  EXPECT_TRUE(link.mapFromOdom(0).isApprox(defaultT_base_camera()))
      << "before any correction: where the server places a new chain, the camera mount";
  sendKeyframes(link, 3, 0, 0);
  sendKeyframes(link, 2, 1, 3);
  ASSERT_TRUE(link.waitForCorrection(4, 5.0));
  EXPECT_LT(testing::maxPoseDifference(link.mapFromOdom(0), testPose(7)), 1e-9);
  EXPECT_LT(testing::maxPoseDifference(link.mapFromOdom(1), testPose(-3)), 1e-9);
  EXPECT_TRUE(link.mapFromOdom(2).isApprox(defaultT_base_camera())) << "an uncorrected segment: the mount";
  ASSERT_TRUE(link.correctedKeyframe(2).has_value());
  EXPECT_LT(testing::maxPoseDifference(*link.correctedKeyframe(2), testPose(7) * testPose(2)), 1e-9);
  const int64_t revision = link.stats().graph_revision;
  EXPECT_EQ(revision, 5);

  // An older revision is ignored; a newer one is applied.
  msg::PoseCorrections stale;
  stale.robot_id = "robot0";
  stale.graph_revision = revision;
  stale.keyframes = {{2, testPose(20)}};
  ASSERT_TRUE(server.send(stale));
  msg::PoseCorrections newer = stale;
  newer.graph_revision = revision + 1;
  newer.keyframes = {{1, testPose(11) * testPose(1)}};
  ASSERT_TRUE(server.send(newer));
  ASSERT_TRUE(server.waitFor([&](auto&) { return link.stats().graph_revision == revision + 1; }));
  EXPECT_EQ(link.stats().corrections_stale, 1u);
  EXPECT_LT(testing::maxPoseDifference(*link.correctedKeyframe(2), testPose(7) * testPose(2)), 1e-9);
  // Segment 0's newest corrected keyframe is still 2 (corrected at revision 5), so its anchor stays.
  EXPECT_LT(testing::maxPoseDifference(link.mapFromOdom(0), testPose(7)), 1e-9);
  EXPECT_LT(testing::maxPoseDifference(*link.correctedKeyframe(1), testPose(11) * testPose(1)), 1e-9);
}

TEST(RobotLink, LatestSliceCommandAndStatusAreKept) {
  auto transport = testing::makeMemq();
  FakeMapServer server(*transport, serverOptions(linkKey(5)));
  server.start();
  RobotLink link(*transport, linkOptions("robot0", linkKey(5)));
  ASSERT_TRUE(link.start());
  EXPECT_FALSE(link.latestSlice() || link.latestCommand() || link.latestServerStatus());
  for (int i = 1; i <= 2; ++i) {
    msg::OccupancySlice slice;
    slice.robot_id = "robot0";
    slice.width = 2 * i;
    slice.height = 3;
    slice.cells.assign(6 * i, msg::OccupancySlice::kFree);
    ASSERT_TRUE(server.send(slice));
    msg::VelocityCommand cmd;
    cmd.robot_id = "robot0";
    cmd.linear_mps = Vec3(0.1 * i, 0, 0);
    cmd.duration_s = 0.5;
    ASSERT_TRUE(server.send(cmd));
    msg::ServerStatus status;
    status.graph_revision = i;
    ASSERT_TRUE(server.send(status));
  }
  ASSERT_TRUE(server.waitFor([&](auto&) { return link.stats().status_received == 2; }));
  ASSERT_TRUE(server.waitFor([&](auto&) { return link.stats().slices_received == 2; }));
  ASSERT_TRUE(server.waitFor([&](auto&) { return link.stats().commands_received == 2; }));
  EXPECT_EQ(link.latestSlice()->width, 4);
  EXPECT_DOUBLE_EQ(link.latestCommand()->linear_mps.x(), 0.2);
  EXPECT_EQ(link.latestServerStatus()->graph_revision, 2);
}

TEST(RobotLink, GarbageForgedReplayedAndMisaddressedMessagesAreRejected) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions(linkKey(6));
  so.ack = false;
  so.send_corrections = false;  // the only genuine server messages are the ones sent below
  FakeMapServer server(*transport, so);
  server.start();
  RobotLink link(*transport, linkOptions("robot0", linkKey(6)));
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 1);
  const std::string ack_channel = *msg::channelFor(msg::MessageType::kKeyframeAck, "robot0");
  const std::string corr_channel = *msg::channelFor(msg::MessageType::kPoseCorrections, "robot0");
  int expected = 0;
  std::mt19937 rng(6);
  for (int i = 0; i < 20; ++i, ++expected) {  // random bytes of random length
    msg::Bytes junk(1 + rng() % 300);
    for (auto& b : junk) b = static_cast<uint8_t>(rng());
    ASSERT_TRUE(transport->publish(i % 2 ? ack_channel : corr_channel, junk));
  }
  msg::Signer forger(msg::kServerId, linkKey(99));  // wrong key
  msg::PoseCorrections forged;
  forged.robot_id = "robot0";
  forged.graph_revision = 100;
  forged.keyframes = {{0, testPose(50)}};
  ASSERT_TRUE(transport->publish(corr_channel, sealOrFail(forger, forged)));
  ++expected;
  msg::Signer genuine(msg::kServerId, linkKey(6), msg::newSessionId() + 1000000);
  // A valid ServerStatus, but on the ack channel.
  const msg::ServerStatus status;
  ASSERT_TRUE(transport->publish(ack_channel, sealOrFail(genuine, status)));
  ++expected;
  const msg::Bytes other_robot = sealOrFail(genuine, testing::makeAck("robot1", 0));
  ASSERT_TRUE(transport->publish(ack_channel, other_robot));  // misaddressed
  ++expected;
  ASSERT_TRUE(transport->publish(ack_channel, other_robot));  // and replayed
  ++expected;
  ASSERT_TRUE(server.waitFor([&](auto&) { return link.stats().messages_rejected >= uint64_t(expected); }));
  EXPECT_EQ(link.stats().messages_rejected, uint64_t(expected));
  EXPECT_EQ(link.stats().keyframes_acked, 0u);
  EXPECT_EQ(link.stats().corrections_received, 0u);
  EXPECT_TRUE(link.mapFromOdom(0).isApprox(defaultT_base_camera()));
  // The genuine server is still heard afterwards.
  ASSERT_TRUE(transport->publish(ack_channel, sealOrFail(genuine, testing::makeAck("robot0", 0))));
  EXPECT_TRUE(link.waitAllAcked(5.0));
}

TEST(RobotLink, WrongKeysAreRejectedInBothDirections) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions(linkKey(7));
  so.sign_key = linkKey(8);  // the server answers with another key than the robot's
  FakeMapServer server(*transport, so);
  server.start();
  RobotLink link(*transport, linkOptions("robot0", linkKey(7)));
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 2);
  ASSERT_TRUE(server.waitFor([](auto& s) { return s.stored.size() == 2; }));
  EXPECT_FALSE(link.waitAllAcked(0.3));
  EXPECT_EQ(link.stats().keyframes_acked, 0u);
  EXPECT_GE(link.stats().messages_rejected, 2u);
  EXPECT_GE(link.stats().bad_signatures, 2u);
  EXPECT_FALSE(link.stats().server_heard) << "a server that cannot sign for this robot is not heard";
  EXPECT_FALSE(link.correctedKeyframe(0).has_value());

  // A robot signing with a key the server does not hold is refused by the server.
  auto transport2 = testing::makeMemq();
  FakeMapServer server2(*transport2, serverOptions(linkKey(9)));
  server2.start();
  RobotLink intruder(*transport2, linkOptions("robot0", linkKey(10)));
  ASSERT_TRUE(intruder.start());
  sendKeyframes(intruder, 1);
  ASSERT_TRUE(
      server2.waitFor([&](auto&) { return server2.rejects().get(msg::RejectReason::kBadSignature) >= 2; }));
  std::lock_guard<std::mutex> lock(server2.state().mutex);
  EXPECT_EQ(server2.state().stored.size(), 0u);
  EXPECT_EQ(server2.state().hellos, 0);
}

}  // namespace
}  // namespace rgbdmap
