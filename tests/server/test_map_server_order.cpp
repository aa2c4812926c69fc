// Store first, order later: keyframes of a robot delivered out of order, or with one missing for
// good, are each stored and acknowledged at once; the graph takes them in chain order through the reorder
// buffer, and a predecessor that never comes splits the chain, which loop closure re-anchors. Over memq://
// with the recorded keyframe stream of the synthetic loop.
#include <algorithm>
#include <chrono>
#include <functional>
#include <map>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::ateOf;
using testing::eventually;
using testing::freshDir;
using testing::kLoopFrames;
using testing::loopSegment;
using testing::OdometrySegment;
using testing::ScriptedRobot;

MapServerConfig orderConfig(const std::string& dir, double timeout_s, size_t capacity) {
  MapServerConfig config = testing::serverTestConfig(dir);
  config.reorder_timeout_s = timeout_s;
  config.reorder_capacity = capacity;
  return config;
}

/// Sends the keyframes at `order` (indices into seg.keyframes) one by one; each must be acknowledged (and
/// be stored: in the graph or waiting) before the next is sent, whatever came before it.
void deliverOneByOne(ScriptedRobot& robot, const MapServer& server, const OdometrySegment& seg,
                     const std::vector<size_t>& order) {
  robot.hello(seg.camera);
  const MapServerStats before = server.stats();
  int delivered = before.keyframes + before.keyframes_waiting + before.keyframes_deferred;
  for (const size_t i : order) {
    robot.send(seg.keyframes[i]);
    ++delivered;
    ASSERT_TRUE(robot.waitAcked({seg.keyframes[i].keyframe_id}, 60.0))
        << "keyframe " << seg.keyframes[i].keyframe_id << " not acknowledged on arrival";
    EXPECT_TRUE(robot.acks().at(seg.keyframes[i].keyframe_id));
    // Acknowledged once stored: in the graph, waiting for its predecessor, or its placement still to run.
    const MapServerStats s = server.stats();
    EXPECT_EQ(s.keyframes + s.keyframes_waiting + s.keyframes_deferred, delivered)
        << "an acknowledged keyframe is not held";
  }
}

std::vector<size_t> indices(size_t n) {
  std::vector<size_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = i;
  return v;
}

RGBDMAP_TEST_TIER("MapServerOrder.*", "e2e");
TEST(MapServerOrder, ShuffledKeyframesAreAcknowledgedAtOnceAndGiveTheInOrderMap) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GT(seg.keyframes.size(), 20u);
  const size_t n = seg.keyframes.size();
  std::vector<size_t> order = indices(n);
  std::shuffle(order.begin(), order.end(), std::mt19937(11));
  const std::string dir = freshDir("order_shuffled");
  const MapServerConfig config = orderConfig(dir, 3600.0, 10000);  // nothing is given up
  testing::ServerHarness h(config);
  {
    ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
    deliverOneByOne(robot, *h.server, seg, order);
    ASSERT_TRUE(h.server->waitIdle(120.0));
  }
  const double odo = ateOf(seg.gt, testing::odometryTrajectory(seg));
  auto check = [&](const char* when) {
    const MapServerStats s = h.server->stats();
    EXPECT_EQ(s.keyframes, static_cast<int>(n)) << when;
    EXPECT_EQ(s.keyframes_waiting, 0) << when;
    EXPECT_EQ(s.maps, 1) << when;
    EXPECT_EQ(s.robots.size(), 1u);
    const ServerRobotStats r = s.robots.empty() ? ServerRobotStats() : s.robots[0];
    EXPECT_EQ(r.chains, 1) << when << ": the chain is whole";
    EXPECT_EQ(r.chain_splits, 0u) << when;
    const double slam = ateOf(seg.gt, testing::serverTrajectory(*h.server, "robot0"));
    std::printf("[ measured ] %zu keyframes shuffled (%s): %llu out of order, ATE %.4f m (odometry %.4f m)\n",
                n, when, static_cast<unsigned long long>(r.out_of_order), slam, odo);
    EXPECT_LE(slam, 0.65 * odo) << when << ": the in-order bound of MapServer.LoopClosure...";
    return r;
  };
  EXPECT_GT(check("live").out_of_order, n / 4);
  // The store holds them in arrival order; a restart puts them back in chain order.
  h.server->stop();
  h.server.reset();
  h.start(config);
  ASSERT_TRUE(h.server->waitIdle(120.0));
  EXPECT_EQ(h.server->stats().restored_keyframes, static_cast<int>(n));
  check("restored");
}

TEST(MapServerOrder, AKeyframeMissingForGoodSplitsTheChainAndLoopClosureReAnchorsIt) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GT(seg.keyframes.size(), 20u);
  const size_t n = seg.keyframes.size(), missing = n / 2;
  // Retransmissions overtaking each other: shuffled within runs of 6; the keyframe in the middle never comes.
  std::vector<size_t> order;
  std::mt19937 rng(5);
  for (size_t begin = 0; begin < n; begin += 6) {
    std::vector<size_t> run;
    for (size_t i = begin; i < std::min(n, begin + 6); ++i)
      if (i != missing) run.push_back(i);
    std::shuffle(run.begin(), run.end(), rng);
    order.insert(order.end(), run.begin(), run.end());
  }
  testing::ServerHarness h(orderConfig(freshDir("order_missing"), 1.0, 64));
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  deliverOneByOne(robot, *h.server, seg, order);
  // The keyframes behind the gap wait one reorder_timeout_s, then start a new chain.
  ASSERT_TRUE(eventually([&] { return h.server->stats().keyframes == static_cast<int>(n - 1); }, 60.0))
      << "the keyframes behind the gap never entered the graph";
  ASSERT_TRUE(h.server->waitIdle(120.0));
  const MapServerStats s = h.server->stats();
  ASSERT_EQ(s.robots.size(), 1u);
  EXPECT_EQ(s.keyframes_waiting, 0);
  EXPECT_GE(s.robots[0].chain_splits, 1u);
  EXPECT_EQ(s.robots[0].chains, 1 + static_cast<int>(s.robots[0].chain_splits));
  EXPECT_EQ(s.maps, 1) << "the split chain was not re-anchored by loop closure";
  const double slam = ateOf(seg.gt, testing::serverTrajectory(*h.server, "robot0"));
  const double odo = ateOf(seg.gt, testing::odometryTrajectory(seg));
  std::printf(
      "[ measured ] keyframe %zu of %zu missing for good: %llu chain split(s), %llu out of order, ATE %.4f m "
      "(odometry %.4f m)\n",
      missing, n, static_cast<unsigned long long>(s.robots[0].chain_splits),
      static_cast<unsigned long long>(s.robots[0].out_of_order), slam, odo);
  EXPECT_LE(slam, 0.65 * odo) << "the in-order bound";
  EXPECT_TRUE(robot.corrections()) << "the robot hears its corrections";
}

TEST(MapServerOrder, TheReorderBoundGivesUpOnAGapAndALatePredecessorJoinsTheChainAgain) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GE(seg.keyframes.size(), 10u);
  const std::string dir = freshDir("order_bound");
  const MapServerConfig config = orderConfig(dir, 3600.0, 4);  // only the bound gives up
  testing::ServerHarness h(config);
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  // 0 1 2 _ 4 5 6 7: four wait for keyframe 3, within the bound.
  deliverOneByOne(robot, *h.server, seg, {0, 1, 2, 4, 5, 6, 7});
  ASSERT_TRUE(h.server->waitIdle(60.0));
  MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes, 3);
  EXPECT_EQ(s.keyframes_waiting, 4);
  EXPECT_EQ(s.robots[0].keyframes_waiting, 4);
  EXPECT_EQ(s.robots[0].out_of_order, 4u);
  // A fifth: over the bound, the run gives up on keyframe 3 and starts a new chain.
  deliverOneByOne(robot, *h.server, seg, {8});
  ASSERT_TRUE(h.server->waitIdle(60.0));
  s = h.server->stats();
  EXPECT_EQ(s.keyframes, 8);
  EXPECT_EQ(s.keyframes_waiting, 0);
  EXPECT_EQ(s.robots[0].chain_splits, 1u);
  EXPECT_EQ(s.robots[0].chains, 2);
  // Keyframe 3 comes after all: acknowledged, in its chain, and its odometry edge joins the split one.
  deliverOneByOne(robot, *h.server, seg, {3});
  ASSERT_TRUE(h.server->waitIdle(60.0));
  s = h.server->stats();
  EXPECT_EQ(s.keyframes, 9);
  EXPECT_EQ(s.maps, 1) << "the late predecessor's odometry edge joins the two chains";
  EXPECT_EQ(s.robots[0].duplicates, 0u);
  // Restored from the store (arrival order 0 1 2 4 5 6 7 8 3): keyframe 3 now precedes its successors.
  h.server->stop();
  h.server.reset();
  h.start(config);
  ASSERT_TRUE(h.server->waitIdle(60.0));
  s = h.server->stats();
  EXPECT_EQ(s.restored_keyframes, 9);
  EXPECT_EQ(s.maps, 1);
  EXPECT_EQ(s.robots[0].chains, 1);
  EXPECT_EQ(s.robots[0].chain_splits, 0u);
  // Re-sent after the restart: recognised, acknowledged again, not stored twice.
  ScriptedRobot again(*h.transport, "robot0", testing::testKey(1), 100);
  testing::driveRobot(*h.server, again, seg, 4, 6);
  EXPECT_EQ(h.server->stats().keyframes, 9);
  EXPECT_EQ(h.server->stats().robots[0].duplicates, 2u);
}

RGBDMAP_TEST_TIER("MapServerOrder.KeyframesStillWaitingAtStopAreInTheFinalKeyframes", "e2e sanitize");
TEST(MapServerOrder, KeyframesStillWaitingAtStopAreInTheFinalKeyframes) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GE(seg.keyframes.size(), 6u);
  testing::ServerHarness h(orderConfig(freshDir("order_stop"), 3600.0, 64));
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  deliverOneByOne(robot, *h.server, seg, {0, 1, 3, 4, 5});  // 2 never comes; 3, 4, 5 wait for it
  ASSERT_TRUE(h.server->waitIdle(60.0));
  EXPECT_EQ(h.server->stats().keyframes_waiting, 3);
  h.server->stop();
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes_waiting, 0);
  EXPECT_EQ(s.keyframes, 5);
  std::vector<int> ids;
  for (const ServerKeyframe& k : h.server->keyframes()) ids.push_back(k.keyframe_id);
  std::sort(ids.begin(), ids.end());
  std::vector<int> want;
  for (const size_t i : {0, 1, 3, 4, 5}) want.push_back(seg.keyframes[i].keyframe_id);
  std::sort(want.begin(), want.end());
  EXPECT_EQ(ids, want) << "every stored keyframe is in the final keyframe list";
  // Placed by the odometry: relative to keyframe 1 (before the gap) where the robot's odometry put it.
  std::map<int, ServerKeyframe> by_id;
  for (const ServerKeyframe& k : h.server->keyframes()) by_id[k.keyframe_id] = k;
  const ServerKeyframe& a = by_id.at(seg.keyframes[1].keyframe_id);
  const ServerKeyframe& b = by_id.at(seg.keyframes[5].keyframe_id);
  const SE3 map_rel = a.T_map_kf.inverse() * b.T_map_kf, odom_rel = a.T_odom_kf.inverse() * b.T_odom_kf;
  EXPECT_GT(odom_rel.translation().norm(), 0.05) << "the test needs keyframes that moved";
  EXPECT_LT((map_rel.translation() - odom_rel.translation()).norm(), 0.01);
}

}  // namespace
}  // namespace rgbdmap
