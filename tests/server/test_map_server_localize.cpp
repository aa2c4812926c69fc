// Map mode "localize": a robot that asks (Hello) or a server with frozen_map places the robot in the stored
// map by its keyframes' matches and answers with corrections in the map's frame; nothing is stored, the map
// directory does not change; a server that does not allow it refuses the keyframes with the reason.
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include <gtest/gtest.h>

#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::freshDir;
using testing::kLoopFrames;
using testing::loopSegment;
using testing::OdometrySegment;
using testing::ScriptedRobot;
using testing::serverTestConfig;
using Harness = testing::ServerHarness;

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Every file of the map directory with its bytes.
std::map<std::string, std::string> mapFiles(const std::string& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.is_regular_file()) out[e.path().filename().string()] = fileBytes(e.path().string());
  return out;
}

/// The server's status of `robot` (its ServerStatus, as it would be published now).
std::optional<msg::RobotStatus> statusOf(const MapServer& server, const std::string& robot) {
  for (const msg::RobotStatus& r : server.status().robots)
    if (r.robot_id == robot) return r;
  return std::nullopt;
}

/// Sends every keyframe of `seg` as a localising robot and waits for their acks; true when all accepted.
/// Before its first keyframe the status says it localises and is not placed yet.
bool localise(const MapServer& server, ScriptedRobot& robot, const OdometrySegment& seg, bool ask) {
  robot.hello(seg.camera, defaultT_base_camera(), ask);
  EXPECT_TRUE(testing::eventually([&] { return statusOf(server, robot.id()).has_value(); }, 10.0));
  const std::optional<msg::RobotStatus> unplaced = statusOf(server, robot.id());
  EXPECT_TRUE(unplaced && unplaced->localize && !unplaced->placed) << "\"unplaced\" in the status";
  std::set<int> ids;
  for (const msg::Keyframe& kf : seg.keyframes) {
    robot.send(kf);
    ids.insert(kf.keyframe_id);
  }
  EXPECT_TRUE(robot.waitAcked(ids, 120.0));
  bool all = true;
  for (const auto& [id, accepted] : robot.acks()) all = all && accepted;
  return all;
}

RGBDMAP_TEST_TIER("MapServerLocalize.*", "e2e sanitize");

TEST(MapServerLocalize, AFrozenMapPlacesTheRobotWhereTheMapHasItAndDoesNotChange) {
  // A third of the loop: short enough for the sanitizer tier.
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames / 3);
  const std::string dir = freshDir("localize_frozen");
  std::map<int, SE3> mapped;  // robot0's keyframes in the map, by keyframe id
  {
    Harness h(dir);
    ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
    testing::driveRobot(*h.server, robot, seg);
    for (const ServerKeyframe& k : h.server->keyframes()) mapped[k.keyframe_id] = k.T_map_kf;
  }
  const auto before = mapFiles(dir);
  MapServerConfig config = serverTestConfig(dir);
  config.frozen_map = true;
  Harness h(config);
  // robot1 goes the same way: every keyframe it sends is one the map holds (robot0's), so its placed pose
  // must be that keyframe's pose in the map. It does not ask: the frozen map puts it in localize mode.
  ScriptedRobot robot(*h.transport, "robot1", testing::testKey(2), 200);
  ASSERT_TRUE(localise(*h.server, robot, seg, false));
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes, static_cast<int>(seg.keyframes.size())) << "the map's keyframes only";
  EXPECT_EQ(s.keyframes_localized, seg.keyframes.size());
  ASSERT_EQ(s.robots.size(), 2u);
  const ServerRobotStats& r1 = s.robots[1];
  EXPECT_EQ(r1.mode, "localize");
  EXPECT_TRUE(r1.placed);
  EXPECT_GE(r1.first_placement_s, 0.0);
  EXPECT_GE(r1.keyframes_matched, seg.keyframes.size() * 9 / 10);
  const std::optional<msg::RobotStatus> placed = statusOf(*h.server, "robot1");
  EXPECT_TRUE(placed && placed->localize && placed->placed) << "placed in the status";
  const std::optional<msg::RobotStatus> mapper = statusOf(*h.server, "robot0");
  EXPECT_TRUE(!mapper || (!mapper->localize && mapper->placed)) << "the stored map's robot";
  // The corrections go out after each acknowledgement: the last ones may still be on their way.
  EXPECT_TRUE(testing::eventually(
      [&] {
        const auto c = robot.correctionsNow();
        return c && c->keyframes.size() == seg.keyframes.size();
      },
      10.0));
  const auto corrections = robot.correctionsNow();
  ASSERT_TRUE(corrections);
  ASSERT_EQ(corrections->keyframes.size(), seg.keyframes.size());
  double worst = 0.0;
  for (const msg::CorrectedPose& c : corrections->keyframes)
    worst = std::max(worst, (c.T_map_cam.translation() - mapped.at(c.keyframe_id).translation()).norm());
  std::printf("[ measured ] localised on the mapped keyframes: worst position %.4f m from the map's\n",
              worst);
  EXPECT_LT(worst, 0.01);
  h.server->stop();
  EXPECT_EQ(mapFiles(dir), before) << "a frozen map's directory changed";
}

// The stored map's own robot id coming back to localise is unplaced until its own keyframes place it: the
// stored keyframes of that id do not count.
TEST(MapServerLocalize, TheMapsOwnRobotIdIsUnplacedUntilItsKeyframesPlaceIt) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames / 3);
  const std::string dir = freshDir("localize_same_id");
  {
    Harness h(dir);
    ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
    testing::driveRobot(*h.server, robot, seg);
  }
  MapServerConfig config = serverTestConfig(dir);
  config.frozen_map = true;
  Harness h(config);
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 300);
  robot.hello(seg.camera, defaultT_base_camera(), false);
  // Known from the store before its Hello (mapping); localising once the Hello is in.
  ASSERT_TRUE(testing::eventually(
      [&] {
        const std::optional<msg::RobotStatus> r = statusOf(*h.server, "robot0");
        return r && r->localize;
      },
      10.0));
  EXPECT_FALSE(statusOf(*h.server, "robot0")->placed) << "placed by the stored keyframes of its id";
}

TEST(MapServerLocalize, ARobotAsksToLocalizeAndIsRefusedWhereTheServerDoesNotAllowIt) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames / 3);
  const std::string dir = freshDir("localize_refused");
  MapServerConfig config = serverTestConfig(dir);
  config.allow_localize = false;
  Harness h(config);
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  EXPECT_FALSE(localise(*h.server, robot, seg, true));
  for (const auto& [id, accepted] : robot.acks()) EXPECT_FALSE(accepted) << "keyframe " << id;
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes, 0);
  EXPECT_EQ(s.keyframes_refused, seg.keyframes.size());
  EXPECT_EQ(fileBytes(dir + "/robots.txt").find("robot0"), std::string::npos)
      << "a localising robot was persisted";
}

}  // namespace
}  // namespace rgbdmap
