// Corrections that follow the robots' heartbeats: a robot whose last keyframe closed no loop
// still hears where it is, and the corrections covering it are sent again while the robot is heard (the
// first may have been lost), a bounded number of times. Over memq:// with the recorded synthetic loop.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

bool coversKeyframe(const std::optional<msg::PoseCorrections>& c, int keyframe_id) {
  if (!c) return false;
  for (const msg::CorrectedPose& p : c->keyframes)
    if (p.keyframe_id == keyframe_id) return true;
  return false;
}

/// Heartbeats naming `last` every 0.2 s until pred() holds or timeout_s passed.
bool heartbeatUntil(testing::ScriptedRobot& robot, const msg::Keyframe& last,
                    const std::function<bool()>& pred, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    msg::Heartbeat hb;
    hb.robot_id = "robot0";
    hb.last_keyframe_id = last.keyframe_id;
    hb.segment_id = last.segment_id;
    robot.publish(hb);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return true;
}

RGBDMAP_TEST_TIER("CorrectionsFollowHeartbeats.*", "e2e");
TEST(CorrectionsFollowHeartbeats, ALastKeyframeWithoutLoopsIsCoveredAndSentAgainWhileTheRobotIsHeard) {
  const testing::OdometrySegment& seg = testing::loopSegment(testing::kLoopFrames, 0, 30);
  ASSERT_GE(seg.keyframes.size(), 3u);
  MapServerConfig config = testing::serverTestConfig(testing::freshDir("corrections_follow"));
  config.loop.verify.min_inliers = config.loop.verify.min_inliers_retrieval = 10000;  // no loop closes
  // Without bundle adjustment nothing else optimises either (with it, every keyframe is optimised and
  // covered at once: MapServerBundle.*).
  config.ba.enabled = false;
  testing::ServerHarness h(config);
  testing::ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, seg);
  const msg::Keyframe& last = seg.keyframes.back();
  ASSERT_EQ(h.server->stats().loops_accepted, 0);
  EXPECT_EQ(h.server->stats().optimizations, 0);
  EXPECT_FALSE(robot.correctionsNow()) << "corrections came without an optimisation";
  // The robot names its last keyframe: within a few ticks, corrections cover it.
  ASSERT_TRUE(heartbeatUntil(
      robot, last, [&] { return coversKeyframe(robot.correctionsNow(), last.keyframe_id); }, 15.0))
      << "no corrections ever covered the robot's last keyframe";
  EXPECT_GE(h.server->stats().optimizations_for_heartbeats, 1u);
  // Heard on: the same corrections again, a bounded number of times (8 sends in all).
  const int revision_messages = robot.correctionMessages();
  heartbeatUntil(
      robot, last, [] { return false; }, 8.0);
  const MapServerStats s = h.server->stats();
  std::printf("[ measured ] corrections resent %llu, optimisations for heartbeats %llu, messages %d\n",
              static_cast<unsigned long long>(s.corrections_resent),
              static_cast<unsigned long long>(s.optimizations_for_heartbeats), robot.correctionMessages());
  EXPECT_GE(s.corrections_resent, 3u);
  EXPECT_LE(s.corrections_resent, 7u);
  EXPECT_GE(robot.correctionMessages(), revision_messages + 3);
  EXPECT_EQ(s.optimizations_for_heartbeats, 1u) << "one optimisation per keyframe named, not one per tick";
  // Not heard any more: nothing more is sent.
  const int after = robot.correctionMessages();
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  EXPECT_EQ(robot.correctionMessages(), after);
}

}  // namespace
}  // namespace rgbdmap
