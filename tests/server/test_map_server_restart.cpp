// The mapping server across restarts on the same map directory: no acknowledged keyframe lost, features the
// server extracted stored and read back (also paged out of RAM), corrections for a robot that says no Hello
// again, a restarted robot re-anchored as a new chain by loop closure.
#include <thread>

#include <gtest/gtest.h>

#include "server/server_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::ateOf;
using testing::freshDir;
using testing::kLoopFrames;
using testing::loopSegment;
using testing::OdometrySegment;
using testing::ScriptedRobot;
using testing::serverTestConfig;

/// The real server over memq:// with robot0 and robot1.
using Harness = testing::ServerHarness;

TEST(MapServer, RestartOnTheSameMapDirectoryLosesNoAcknowledgedKeyframe) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  const std::string dir = freshDir("restart");
  const size_t half = seg.keyframes.size() / 2;
  Harness h(dir);
  {
    ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
    testing::driveRobot(*h.server, robot, seg, 0, half);
    EXPECT_EQ(h.server->stats().keyframes, static_cast<int>(half));
  }
  h.server->stop();
  h.server.reset();  // "killed": everything acknowledged is on disk
  h.start(serverTestConfig(dir));
  EXPECT_EQ(h.server->stats().restored_keyframes, static_cast<int>(half));
  // The stored loops' inlier matches rebuild the landmark tracks of the restored keyframes.
  EXPECT_TRUE(h.server->waitIdle(30.0));
  const BundleAdjustmentStats restored = h.server->stats().ba;
  EXPECT_GT(restored.edges_in_tracks, 0);
  EXPECT_GT(restored.landmarks.landmarks, 500) << "restored keyframes without landmark tracks";
  // The same robot process goes on: it re-sends its last three keyframes (acks it never saw) and the rest.
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, seg, half - 3, seg.keyframes.size());
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes, static_cast<int>(seg.keyframes.size())) << "keyframes lost or duplicated";
  ASSERT_EQ(s.robots.size(), 1u);
  EXPECT_EQ(s.robots[0].duplicates, 3u);
  // Decoded off the ingest worker, all of them (robots.txt gave the camera); the resends not at all.
  EXPECT_EQ(s.keyframes_decoded, seg.keyframes.size() - half);
  EXPECT_EQ(s.keyframes_decoded_ahead, seg.keyframes.size() - half) << "resends decoded again, or inline";
  EXPECT_EQ(s.robots[0].chains, 1) << "the restart must continue the same odometry chain";
  const double slam = ateOf(seg.gt, testing::serverTrajectory(*h.server, "robot0"));
  const double odo = ateOf(seg.gt, testing::odometryTrajectory(seg));
  std::printf("[ measured ] restart mid-run: ATE %.4f m (odometry %.4f m)\n", slam, odo);
  // Measured 0.0037 m, as without a restart (0.0037-0.0039 m; 0.0051 m before the stored loops kept
  // their inlier matches).
  EXPECT_LE(slam, 0.55 * odo) << "a restart must not cost accuracy";
}

/// The segment's keyframes as a robot sends them by default (link.send_features: false).
OdometrySegment withoutFeatures(const OdometrySegment& seg) {
  OdometrySegment stripped{seg.camera, seg.gt, seg.keyframes};
  for (msg::Keyframe& kf : stripped.keyframes) {
    kf.keypoints.clear();
    kf.descriptors.clear();
  }
  return stripped;
}

// Keyframes sent without features (the robot's default, link.send_features: false): the server extracts
// them from the decoded colour, stores them with the keyframe, and a restarted server reads them back
// (landmark tracks, loop closure and the accuracy of the synthetic loop as with the robot's features).
TEST(MapServer, FeaturesExtractedByTheServerAreStoredAndSurviveARestart) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  const OdometrySegment stripped = withoutFeatures(seg);
  const std::vector<msg::Keyframe>& bare = stripped.keyframes;
  const std::string dir = freshDir("server_features");
  const size_t half = bare.size() / 2;
  Harness h(dir);
  {
    ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
    testing::driveRobot(*h.server, robot, stripped, 0, half);
    EXPECT_EQ(h.server->stats().keyframes, static_cast<int>(half));
    EXPECT_EQ(h.server->stats().keyframes_features_extracted, half);
  }
  h.server->stop();
  h.server.reset();
  h.start(serverTestConfig(dir));
  EXPECT_EQ(h.server->stats().restored_keyframes, static_cast<int>(half));
  EXPECT_TRUE(h.server->waitIdle(30.0));
  EXPECT_GT(h.server->stats().ba.landmarks.landmarks, 500) << "restored keyframes without their features";
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, stripped, half, bare.size());
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes, static_cast<int>(bare.size()));
  EXPECT_EQ(s.keyframes_features_extracted, bare.size() - half) << "counted since the restart";
  EXPECT_GE(s.loops_accepted, 10);
  const double slam = ateOf(seg.gt, testing::serverTrajectory(*h.server, "robot0"));
  const double odo = ateOf(seg.gt, testing::odometryTrajectory(seg));
  std::printf(
      "[ measured ] features extracted by the server, restart mid-run: ATE %.4f m (odometry %.4f m)\n", slam,
      odo);
  // 0.0049-0.0052 m against the odometry's 0.0092 (the rolling-shutter prior's sigma 0.0025 costs this
  // global-shutter scene ~0.2 mm); restored keyframes without their features would not beat the odometry.
  EXPECT_LE(slam, 0.6 * odo);
}

TEST(MapServer, FeaturesPagedOutOfRamAreReadBackFromTheStoreForLoopsAndBundleAdjustment) {
  // The fleet's mode (features extracted by the server) with the features of only 4 keyframes in RAM: loop
  // candidates, landmark tracks and BA windows read the others back from the store, and the map is as good
  // as with all of them in RAM.
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  const OdometrySegment stripped = withoutFeatures(seg);
  const auto run = [&](size_t features_in_memory, const std::string& name) {
    MapServerConfig config = serverTestConfig(freshDir(name));
    config.features_in_memory = features_in_memory;
    testing::ServerHarness h(config);
    ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
    testing::driveRobot(*h.server, robot, stripped);
    EXPECT_TRUE(h.server->waitIdle(30.0));
    return std::make_pair(h.server->stats(), ateOf(seg.gt, testing::serverTrajectory(*h.server, "robot0")));
  };
  const auto [all, all_ate] = run(0, "features_all");
  const auto [paged, paged_ate] = run(4, "features_paged");
  std::printf(
      "[ measured ] %zu keyframes, features in RAM all / 4: ATE %.4f / %.4f m, loops %d / %d, landmarks %lld "
      "/ "
      "%lld, features read back %llu\n",
      stripped.keyframes.size(), all_ate, paged_ate, all.loops_accepted, paged.loops_accepted,
      static_cast<long long>(all.ba.landmarks.landmarks),
      static_cast<long long>(paged.ba.landmarks.landmarks),
      static_cast<unsigned long long>(paged.features_loads));
  EXPECT_EQ(all.features_loads, 0u);
  EXPECT_EQ(paged.keyframes, static_cast<int>(stripped.keyframes.size()));
  EXPECT_LE(paged.features_resident, 4u);
  EXPECT_GT(paged.features_loads, stripped.keyframes.size()) << "loops and BA needed dropped features";
  EXPECT_EQ(paged.features_load_failures, 0u);
  EXPECT_EQ(paged.loop_features_unavailable, 0);
  EXPECT_GE(paged.loops_accepted, all.loops_accepted * 9 / 10);
  EXPECT_GE(paged.ba.landmarks.landmarks, all.ba.landmarks.landmarks * 9 / 10);
  EXPECT_LE(paged_ate, 1.2 * all_ate + 0.001);
}

TEST(MapServer, AfterARestartARobotThatSaysNoHelloAgainStillGetsCorrections) {
  // Over LCM a robot that heard the killed server does not say Hello to the restarted one (seen in
  // faults.kill9.lcm: no PoseCorrections at all after the first kill -9): its keyframes name its session.
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  const std::string dir = freshDir("restart_no_hello");
  const size_t half = seg.keyframes.size() / 2;
  Harness h(dir);
  {
    ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
    testing::driveRobot(*h.server, robot, seg, 0, half);
  }
  h.server->stop();
  h.server.reset();
  h.start(serverTestConfig(dir));
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  std::set<int> ids;
  for (size_t i = half; i < seg.keyframes.size(); ++i) {
    robot.send(seg.keyframes[i]);
    ids.insert(seg.keyframes[i].keyframe_id);
  }
  EXPECT_TRUE(robot.waitAcked(ids, 120.0));
  EXPECT_TRUE(h.server->waitIdle(120.0));
  ASSERT_TRUE(robot.corrections(10.0)) << "no PoseCorrections for a robot without a Hello after the restart";
  const auto covers_last = [&] {  // corrections arrive asynchronously after the optimisation
    const std::optional<msg::PoseCorrections> c = robot.correctionsNow();
    return std::any_of(c->keyframes.begin(), c->keyframes.end(), [&](const msg::CorrectedPose& p) {
      return p.keyframe_id == seg.keyframes.back().keyframe_id;
    });
  };
  for (int i = 0; i < 100 && !covers_last(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(covers_last());
  ASSERT_EQ(h.server->stats().robots.size(), 1u);
  EXPECT_EQ(h.server->stats().robots[0].sessions, 1);
}

TEST(MapServer, ARestartedRobotContinuesAsANewChainAndIsReAnchoredByLoopClosure) {
  // The robot process restarts half way: a new session, odometry from scratch in a new frame.
  const OdometrySegment& first = loopSegment(kLoopFrames, 0, 170);
  const OdometrySegment& second = loopSegment(kLoopFrames, 130, kLoopFrames);
  Harness h(freshDir("robot_restart"));
  {
    ScriptedRobot before(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
    testing::driveRobot(*h.server, before, first);
  }
  ScriptedRobot after(*h.transport, "robot0", rgbdmap::testing::testKey(1), 200);
  testing::driveRobot(*h.server, after, second);
  const MapServerStats s = h.server->stats();
  ASSERT_EQ(s.robots.size(), 1u);
  EXPECT_EQ(s.robots[0].sessions, 2);
  EXPECT_EQ(s.robots[0].chains, 2);
  EXPECT_EQ(s.keyframes, static_cast<int>(first.keyframes.size() + second.keyframes.size()));
  EXPECT_EQ(s.maps, 1) << "the second chain was not joined to the first";
  // Both chains in one alignment: only a correct re-anchoring puts them in one frame.
  Trajectory all = testing::serverTrajectory(*h.server, "robot0");
  std::sort(all.begin(), all.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  Trajectory distinct;
  for (const StampedPose& p : all)
    if (distinct.empty() || p.timestamp > distinct.back().timestamp + 1e-6) distinct.push_back(p);
  const double joint = ateOf(first.gt, distinct);
  std::printf("[ measured ] restarted robot: two chains re-anchored, joint ATE %.4f m\n", joint);
  EXPECT_LT(joint, 0.01);
  // The restarted process gets corrections for its own keyframes, in the map of the first chain.
  const auto c = after.corrections();
  ASSERT_TRUE(c);
  EXPECT_EQ(c->keyframes.size(), second.keyframes.size());
  EXPECT_FALSE(c->T_map_odom.isApprox(defaultT_base_camera(), 1e-3)) << "not where its own chain started";
}

}  // namespace
}  // namespace rgbdmap
