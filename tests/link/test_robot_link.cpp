// RobotLink over memq:// against a fake server: acks, retransmission, refusals, delivery reports, stop(),
// option checks, two robots on one transport, late handlers, chunking defaults.
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

TEST(RobotLink, SignedKeyframesAreAckedHelloAndHeartbeatsArrive) {
  auto transport = testing::makeMemq();
  FakeMapServer server(*transport, serverOptions(linkKey(1)));
  server.start();
  RobotLink link(*transport, linkOptions("robot0", linkKey(1)));
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 5);
  link.setTrackingState(4, 0, TrackingState::kTracking);
  ASSERT_TRUE(link.waitAllAcked(5.0));
  ASSERT_TRUE(
      server.waitFor([](auto& s) { return s.hellos >= 1 && s.last_heartbeat.last_keyframe_id == 4; }));
  const RobotLinkStats st = link.stats();
  EXPECT_EQ(st.keyframes_sent, 5u);
  EXPECT_EQ(st.keyframes_acked, 5u);
  EXPECT_EQ(st.keyframes_pending, 0u);
  EXPECT_EQ(st.ack_latency_samples, 5u);  // first send to ack, one sample per accepted keyframe
  EXPECT_GT(st.ack_latency_ms_median, 0.0);
  EXPECT_LE(st.ack_latency_ms_median, st.ack_latency_ms_p90);
  EXPECT_LE(st.ack_latency_ms_p90, st.ack_latency_ms_max);
  EXPECT_LT(st.ack_latency_ms_max, 5000.0);
  EXPECT_EQ(st.messages_rejected, 0u);
  EXPECT_GT(st.bytes_sent, 5u * 1000u);
  EXPECT_GT(st.bytes_received, 0u);
  EXPECT_EQ(server.rejects().total(), 0u);
  std::lock_guard<std::mutex> lock(server.state().mutex);
  ASSERT_EQ(server.state().stored.size(), 5u);
  EXPECT_EQ(server.state().stored.at(3).images.width, 64);
  EXPECT_EQ(server.state().stored.at(3).keypoints.size(), 0u) << "send_features is off by default";
  EXPECT_EQ(server.state().last_heartbeat.tracking_state, static_cast<int>(TrackingState::kTracking));
}

// send_features: the keyframes carry the odometry's keypoints and descriptors, and the per-part byte counts
// say what they cost; without, the message is the images and the fields only.
TEST(RobotLink, SendFeaturesPutsTheKeypointsIntoTheKeyframesAndCountsTheirBytes) {
  for (const bool send : {true, false}) {
    auto transport = testing::makeMemq();
    FakeMapServer server(*transport, serverOptions(linkKey(1)));
    server.start();
    RobotLinkOptions o = linkOptions("robot0", linkKey(1));
    o.send_features = send;
    RobotLink link(*transport, o);
    ASSERT_TRUE(link.start());
    sendKeyframes(link, 3);
    ASSERT_TRUE(link.waitAllAcked(5.0));
    const RobotLinkStats st = link.stats();
    EXPECT_EQ(st.keyframe_feature_bytes, send ? 3u * 20u * (21u + 32u) : 0u);
    EXPECT_GT(st.keyframe_depth_bytes, 0u);
    EXPECT_GT(st.keyframe_color_bytes, 0u);
    EXPECT_GT(st.keyframe_message_bytes,
              st.keyframe_depth_bytes + st.keyframe_color_bytes + st.keyframe_feature_bytes);
    std::lock_guard<std::mutex> lock(server.state().mutex);
    ASSERT_EQ(server.state().stored.size(), 3u);
    EXPECT_EQ(server.state().stored.at(2).keypoints.size(), send ? 20u : 0u);
    EXPECT_EQ(server.state().stored.at(2).descriptors.size(), send ? 20u * 32u : 0u);
  }
}

TEST(RobotLink, DroppedKeyframesAreRetransmittedAndStoredOnce) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions(linkKey(2));
  so.ignore_first_transmissions = 4;  // the first transmission of all three keyframes, and one retransmission
  FakeMapServer server(*transport, so);
  server.start();
  RobotLink link(*transport, linkOptions("robot0", linkKey(2)));
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 3);
  ASSERT_TRUE(link.waitAllAcked(10.0));
  const RobotLinkStats st = link.stats();
  EXPECT_EQ(st.keyframes_acked, 3u) << "each id counted once";
  EXPECT_GE(st.retransmissions, 4u);
  std::lock_guard<std::mutex> lock(server.state().mutex);
  EXPECT_EQ(server.state().stored.size(), 3u);
  EXPECT_GE(server.state().transmissions, 7);
}

TEST(RobotLink, DuplicateAcksAreCountedOnce) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions({});
  so.acks_per_keyframe = 3;
  FakeMapServer server(*transport, so);
  server.start();
  RobotLink link(*transport, linkOptions("robot0", {}));  // unsigned: open mode on both sides
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 4);
  ASSERT_TRUE(link.waitAllAcked(5.0));
  ASSERT_TRUE(link.waitForCorrection(3, 5.0));
  const RobotLinkStats st = link.stats();
  EXPECT_EQ(st.keyframes_acked, 4u);
  EXPECT_GE(st.duplicate_acks, 8u) << "3 acks per transmission; more if a retransmission overtook an ack";
  EXPECT_EQ(st.messages_rejected, 0u);
}

TEST(RobotLink, RefusedKeyframeIsCountedAndNotResent) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions(linkKey(3));
  so.refuse_ids = {1};
  FakeMapServer server(*transport, so);
  server.start();
  RobotLink link(*transport, linkOptions("robot0", linkKey(3)));
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 3);
  ASSERT_TRUE(link.waitAllAcked(5.0)) << "a refusal is an answer";
  int receptions = 0;  // 1, or more if a retransmission overtook the refusal on a loaded machine
  server.waitFor([&](auto& s) { return (receptions = s.receptions[1]) > 0; });
  // Several backoff periods (20-100 ms) later the refused keyframe must not have come again.
  EXPECT_FALSE(server.waitFor([&](auto& s) { return s.receptions[1] > receptions; }, 0.5));
  const RobotLinkStats st = link.stats();
  EXPECT_EQ(st.keyframes_refused, 1u);
  EXPECT_EQ(st.keyframes_acked, 2u);
  EXPECT_EQ(st.keyframes_pending, 0u);
  EXPECT_FALSE(link.correctedKeyframe(1).has_value());
  EXPECT_TRUE(st.server_heard);
  EXPECT_EQ(st.refused_by_reason, (std::map<std::string, uint64_t>{{"test refusal", 1}}));
  // What rgbdmap-client tells its operator (and exits 3 on): a server answered, one keyframe refused, why.
  RobotRunResult run;
  run.keyframes = 3;
  run.link = st;
  const DeliveryReport d = deliveryReport(run);
  EXPECT_EQ(d.unaccepted, 1);
  EXPECT_NE(d.message.find("1 of 3 keyframes not accepted"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("by the server (it was heard): 1 refused (1 x \"test refusal\")"),
            std::string::npos)
      << d.message;
}

TEST(RobotLink, DeliveryReportSaysWhetherAnyServerWasHeard) {
  RobotRunResult run;
  run.keyframes = 4;
  run.link.keyframes_acked = 4;
  EXPECT_EQ(deliveryReport(run).unaccepted, 0);
  EXPECT_EQ(deliveryReport(run).message, "");
  run.link.keyframes_acked = 0;
  run.link.keyframes_pending = 3;
  run.keyframes_not_sent = 1;
  DeliveryReport d = deliveryReport(run);
  EXPECT_EQ(d.unaccepted, 4);
  EXPECT_NE(d.message.find("4 of 4 keyframes not accepted: no server heard at all"), std::string::npos)
      << d.message;
  EXPECT_NE(d.message.find("holds this robot's key"), std::string::npos) << d.message;
  run.link.bad_signatures = 5;
  EXPECT_NE(deliveryReport(run).message.find("5 messages with a bad signature"), std::string::npos);
  run.link.server_heard = true;  // heard, but nothing answered in time
  run.link.keyframes_acked = 1;
  run.link.keyframes_pending = 2;
  d = deliveryReport(run);
  EXPECT_EQ(d.unaccepted, 3);
  EXPECT_NE(d.message.find("(it was heard): 2 still unanswered after link.final_wait_s, 1 not sent"),
            std::string::npos)
      << d.message;
}

TEST(RobotLink, DeliveryReportSaysWhyFromTheServersCountersForThisRobot) {
  RobotRunResult run;
  run.keyframes = 5;
  run.link.keyframes_pending = 5;
  run.link.bad_signatures = 7;
  run.link.server_status_seen = true;
  run.link.server_rejects = {{"bad_signature", 12}};
  run.link.server_rejects_verified = false;  // a robot with a wrong key cannot verify the status
  DeliveryReport d = deliveryReport(run, "robot0");
  EXPECT_EQ(d.unaccepted, 5);
  EXPECT_NE(d.message.find("5 of 5 keyframes not accepted: the server refused 12 messages from robot0 "
                           "(hellos, heartbeats, keyframe chunks) for a bad signature (wrong key?)"),
            std::string::npos)
      << d.message;
  EXPECT_NE(d.message.find("could not verify (7 bad signatures here)"), std::string::npos) << d.message;
  // Heard, refused, with other rejects reported by the server.
  run.link = RobotLinkStats{};
  run.link.server_heard = true;
  run.link.keyframes_acked = 3;
  run.link.keyframes_refused = 2;
  run.link.refused_by_reason = {{"camera mismatch", 2}};
  run.link.server_rejects = {{"replayed_seq", 4}};
  run.link.server_rejects_verified = true;
  d = deliveryReport(run, "robot0");
  EXPECT_NE(d.message.find("refused: 2 x \"camera mismatch\""), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("the server reports rejected messages from robot0: 4 replayed_seq"),
            std::string::npos)
      << d.message;
  // Heard, nothing refused, nothing acknowledged in time.
  run.link.keyframes_refused = 0;
  run.link.refused_by_reason.clear();
  run.link.server_rejects.clear();
  run.link.keyframes_pending = 2;
  d = deliveryReport(run, "robot0");
  EXPECT_NE(d.message.find("server heard but no ack (loss?)"), std::string::npos) << d.message;
}

/// A ServerStatus naming `robot` with `bad` bad signatures, signed as the server with `key`.
TEST(RobotLink, StopIsPromptAndWakesBlockedCalls) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions({});
  so.ack = false;  // nothing is ever acknowledged: the send window fills
  FakeMapServer server(*transport, so);
  server.start();
  RobotLinkOptions lo = linkOptions("robot0", {});
  lo.reliable.max_pending = 2;
  lo.send_timeout_s = 60.0;
  RobotLink link(*transport, lo);
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 2);
  auto blocked = std::async(
      std::launch::async, [&] { return link.sendKeyframe(smallKeyframe(2, 0, testPose(2)), smallFrame(2)); });
  auto waiting = std::async(std::launch::async, [&] { return link.waitAllAcked(60.0); });
  EXPECT_EQ(blocked.wait_for(std::chrono::milliseconds(200)), std::future_status::timeout) << "window full";
  const auto t0 = std::chrono::steady_clock::now();
  link.stop();
  link.stop();  // idempotent
  ASSERT_EQ(blocked.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  ASSERT_EQ(waiting.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0)
      << "stop() must not wait for the 60 s timeouts";
  EXPECT_FALSE(blocked.get());
  EXPECT_FALSE(waiting.get());
  EXPECT_FALSE(link.sendKeyframe(smallKeyframe(3, 0, testPose(3)), smallFrame(3))) << "stopped";
  EXPECT_FALSE(link.start()) << "no restart";
}

TEST(RobotLink, InvalidOptionsAndInputsAreErrors) {
  auto transport = testing::makeMemq();
  RobotLinkOptions bad = linkOptions("robot 0", msg::Bytes(5, 1));
  bad.heartbeat_period_s = 0.0;
  const std::string reasons = bad.validate();
  EXPECT_NE(reasons.find("robot id"), std::string::npos) << reasons;
  EXPECT_NE(reasons.find("key"), std::string::npos) << reasons;
  EXPECT_NE(reasons.find("heartbeat_period_s"), std::string::npos) << reasons;
  RobotLink link(*transport, bad);
  EXPECT_FALSE(link.start());
  EXPECT_FALSE(RobotLink(*transport, linkOptions(msg::kServerId, {})).start());

  RobotLink good(*transport, linkOptions("robot0", {}));
  ASSERT_TRUE(good.start());
  RgbdFrame empty;
  EXPECT_FALSE(good.sendKeyframe(smallKeyframe(0, 0, testPose(0)), empty)) << "no images";
  EXPECT_FALSE(good.sendKeyframe(smallKeyframe(-1, 0, testPose(0)), smallFrame(0))) << "negative id";
  ASSERT_TRUE(good.sendKeyframe(smallKeyframe(1, 0, testPose(1)), smallFrame(1)));
  EXPECT_FALSE(good.sendKeyframe(smallKeyframe(1, 0, testPose(1)), smallFrame(1))) << "same id twice";
  EXPECT_EQ(good.stats().keyframes_sent, 1u);
}

TEST(RobotLink, TwoRobotsShareOneTransport) {
  auto transport = testing::makeMemq();
  FakeServerOptions a = serverOptions(linkKey(11)), b = serverOptions(linkKey(12));
  a.robot_id = "alpha";
  b.robot_id = "beta";
  a.T_map_odom = {{0, testPose(1)}};
  b.T_map_odom = {{0, testPose(-2)}};
  FakeMapServer server_a(*transport, a), server_b(*transport, b);
  server_a.start();
  server_b.start();
  RobotLink alpha(*transport, linkOptions("alpha", linkKey(11)));
  RobotLink beta(*transport, linkOptions("beta", linkKey(12)));
  ASSERT_TRUE(alpha.start());
  ASSERT_TRUE(beta.start());
  sendKeyframes(alpha, 3);
  sendKeyframes(beta, 2);
  ASSERT_TRUE(alpha.waitForCorrection(2, 5.0));
  ASSERT_TRUE(beta.waitForCorrection(1, 5.0));
  EXPECT_TRUE(alpha.waitAllAcked(5.0) && beta.waitAllAcked(5.0));
  EXPECT_LT(testing::maxPoseDifference(alpha.mapFromOdom(0), testPose(1)), 1e-9);
  EXPECT_LT(testing::maxPoseDifference(beta.mapFromOdom(0), testPose(-2)), 1e-9);
  EXPECT_EQ(alpha.stats().keyframes_acked, 3u);
  EXPECT_EQ(beta.stats().keyframes_acked, 2u);
  EXPECT_EQ(alpha.stats().messages_rejected + beta.stats().messages_rejected, 0u)
      << "each hears only its own";
}

TEST(RobotLink, HandlersAreHarmlessAfterTheLinkIsGone) {
  auto transport = testing::makeMemq();
  FakeMapServer server(*transport, serverOptions({}));
  server.start();
  {
    RobotLink link(*transport, linkOptions("robot0", {}));
    ASSERT_TRUE(link.start());
    sendKeyframes(link, 2);
    ASSERT_TRUE(link.waitAllAcked(5.0));
  }
  // Its subscriptions remain in the transport; messages on them must do nothing (ASan watches).
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(server.send(testing::makeAck("robot0", i)));
  RobotLink again(*transport, linkOptions("robot0", {}));  // a restarted robot on the same transport
  ASSERT_TRUE(again.start());
  sendKeyframes(again, 1, 0, 10);
  EXPECT_TRUE(again.waitAllAcked(5.0));
}

TEST(RobotLink, ChunksByDefaultOnLcmOnly) {
  EXPECT_EQ(resolveChunkBytes(-1, "udpm://239.255.76.67:7667?ttl=0"), 1100);
  EXPECT_EQ(resolveChunkBytes(-1, "dds://?domain=0"), 0);
  EXPECT_EQ(resolveChunkBytes(-1, "memq://"), 0);
  EXPECT_EQ(resolveChunkBytes(0, "udpm://239.255.76.67:7667"), 0) << "whole keyframes when configured";
  EXPECT_EQ(resolveChunkBytes(2000, "memq://"), 2000);
}

}  // namespace
}  // namespace rgbdmap
