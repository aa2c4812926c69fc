// The z-up map frame (REP-103) and the map stream's latency through the real server on the recorded
// synthetic loop: the map is the base frame of the first robot's first keyframe (its Hello's camera mount),
// slices and the global 2-D map (map_<id>.pgm/.yaml) are axis-aligned horizontal cuts, and a keyframe's
// voxels go out within the stream delay of its insertion, not at the next stream period.
#include <algorithm>
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "rgbdmap/export/slice_export.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::kLoopFrames;
using testing::loopSegment;
using testing::OdometrySegment;
using testing::ScriptedRobot;

MapServerConfig frameConfig(const std::string& name) {
  MapServerConfig config = testing::serverTestConfig(testing::freshDir("frame_" + name), {"robot0"});
  config.slice_period_s = 0.0;
  return config;
}

/// The ground-truth camera pose at a keyframe's stamp.
SE3 truthAt(const OdometrySegment& seg, double timestamp) {
  const StampedPose* best = &seg.gt.front();
  for (const StampedPose& p : seg.gt)
    if (std::abs(p.timestamp - timestamp) < std::abs(best->timestamp - timestamp)) best = &p;
  return best->T_world_cam;
}

double angleDeg(const Mat3& R) { return Eigen::AngleAxisd(R).angle() * 180.0 / M_PI; }
double maxDifference(const SE3& a, const SE3& b) { return (a.matrix() - b.matrix()).cwiseAbs().maxCoeff(); }

RGBDMAP_TEST_TIER("MapServerFrame.*", "e2e");
TEST(MapServerFrame, MapIsTheBaseFrameOfTheFirstKeyframeAndItsGridsAreAxisAligned) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GT(seg.keyframes.size(), 20u);
  // The robot's base is the world frame moved under the first camera: a mount that says where the camera
  // really sits (1.35 m up, the synthetic camera's pitch and roll) makes the map the world, shifted.
  const SE3 T_world_cam0 = truthAt(seg, seg.keyframes.front().timestamp);
  SE3 T_base_camera = T_world_cam0;
  T_base_camera.translation() = Vec3(0, 0, T_world_cam0.translation().z());
  testing::ServerHarness h(frameConfig("mount"));
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  robot.hello(seg.camera, T_base_camera);
  std::set<int> ids;
  for (size_t i = 0; i < 24; ++i) {
    robot.send(seg.keyframes[i]);
    ids.insert(seg.keyframes[i].keyframe_id);
  }
  ASSERT_TRUE(robot.waitAcked(ids, 120.0));
  ASSERT_TRUE(h.server->waitIdle(120.0));

  const std::vector<ServerKeyframe> kfs = h.server->keyframes();
  ASSERT_FALSE(kfs.empty());
  EXPECT_LT(maxDifference(kfs.front().T_map_kf, T_base_camera * seg.keyframes.front().T_odom_cam), 1e-9)
      << "the first chain's anchor: T_map_odom = T_base_camera";
  // world <- map: the first keyframe's truth times its map pose inverted = the base frame's shift.
  const SE3 T_world_map = T_world_cam0 * kfs.front().T_map_kf.inverse();
  EXPECT_LT(angleDeg(T_world_map.linear()), 0.01) << "map axes = world axes: z is up";
  EXPECT_NEAR(T_world_map.translation().z(), 0.0, 1e-6) << "map z = 0 is the floor (the base)";
  double worst_deg = 0;  // every keyframe's map pose is its true pose in the world, up to odometry drift
  for (const ServerKeyframe& k : kfs)
    worst_deg = std::max(worst_deg, angleDeg((T_world_map * k.T_map_kf).linear().transpose() *
                                             truthAt(seg, k.timestamp).linear()));
  EXPECT_LT(worst_deg, 2.0);

  const auto slice = robot.lastSlice();
  ASSERT_TRUE(slice);
  EXPECT_TRUE(slice->T_map_grid.linear().isApprox(Mat3::Identity(), 1e-9)) << "slices have no yaw";
  EXPECT_NEAR(slice->T_map_grid.translation().z(), kfs.back().T_map_kf.translation().z(), 0.05)
      << "cut at the robot's camera height";

  const std::string out = testing::freshDir("frame_mount_out");
  ASSERT_TRUE(h.server->writeMapOutputs(out));
  const int map_id = kfs.front().map_id;
  const std::string yaml = out + "/map_" + std::to_string(map_id) + ".yaml";
  ASSERT_TRUE(std::filesystem::exists(out + "/map_" + std::to_string(map_id) + ".pgm"));
  auto grid = readSlice(yaml);
  ASSERT_TRUE(grid) << grid.error();
  EXPECT_TRUE(grid->T_map_grid.linear().isApprox(Mat3::Identity(), 1e-6)) << "the 2-D map has no yaw";
  EXPECT_NEAR(grid->T_map_grid.translation().z(), 1.35, 0.1) << "cut at the cameras' height";
  // The file holds the cut of the written map.bt at that height (trinary: occupied / free / unknown).
  auto bt = readMapFile(out + "/map.bt");
  ASSERT_TRUE(bt) << bt.error();
  auto cut = extractMapGrid(**bt, grid->T_map_grid.translation().z(), MapServerConfig{}.slice);
  ASSERT_TRUE(cut) << cut.error();
  EXPECT_EQ(cut->width, grid->width);
  EXPECT_EQ(cut->height, grid->height);
  EXPECT_EQ(cut->cells, grid->cells);
  const auto count = [&](int8_t v) { return std::count(grid->cells.begin(), grid->cells.end(), v); };
  EXPECT_GT(count(msg::OccupancySlice::kOccupied), 200) << "walls and furniture";
  EXPECT_GT(count(msg::OccupancySlice::kFree), 2000) << "the room's floor space";
}

TEST(MapServerFrame, DefaultMountIsALevelForwardCamera) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  testing::ServerHarness h(frameConfig("default"));
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, seg, 0, 3);
  const std::vector<ServerKeyframe> kfs = h.server->keyframes();
  ASSERT_EQ(kfs.size(), 3u);
  EXPECT_LT(maxDifference(kfs.front().T_map_kf, defaultT_base_camera() * seg.keyframes.front().T_odom_cam),
            1e-9);
  // The synthetic camera looks 6.9 degrees down: with the default (level) mount, the map's up is the first
  // camera's up, that far off the world's.
  const SE3 T_world_map = truthAt(seg, kfs.front().timestamp) * kfs.front().T_map_kf.inverse();
  EXPECT_NEAR(angleDeg(T_world_map.linear()), 6.9, 0.5);
}

/// Per keyframe, sent one at a time: the time from its acknowledgement to the first MapUpdate that holds it.
std::vector<double> ackToMapSeconds(const MapServerConfig& config, size_t keyframes, double timeout_s) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  testing::ServerHarness h(config);
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  robot.hello(seg.camera);
  std::vector<double> seconds;
  for (size_t i = 0; i < keyframes; ++i) {
    const int id = seg.keyframes[i].keyframe_id;
    robot.send(seg.keyframes[i]);
    EXPECT_TRUE(robot.waitAcked({id}, 60.0));
    const auto ack = robot.ackTime(id);
    const auto map = robot.waitMapWithKeyframe(id, timeout_s);
    if (ack && map) seconds.push_back(std::chrono::duration<double>(*map - *ack).count());
  }
  return seconds;
}

TEST(MapServerFrame, MapStreamFollowsEachKeyframeWithinTheDelay) {
  MapServerConfig config = frameConfig("stream");
  config.map_stream_period_s = 30.0;  // the periodic stream alone would not send anything in this test
  config.map_stream_delay_s = 0.25;
  std::vector<double> s = ackToMapSeconds(config, 8, 10.0);
  ASSERT_EQ(s.size(), 8u) << "every keyframe's voxels reached the robot";
  std::sort(s.begin(), s.end());
  std::printf("[ measured ] keyframe ack -> MapUpdate holding it: median %.0f ms, max %.0f ms\n",
              1e3 * s[s.size() / 2], 1e3 * s.back());
  EXPECT_LT(s[s.size() / 2], 1.0);

  config = frameConfig("stream_off");
  config.map_stream_period_s = 30.0;
  config.map_stream_delay_s = 0.0;  // only periodically: nothing within 2 s
  EXPECT_TRUE(ackToMapSeconds(config, 1, 2.0).empty());
}

}  // namespace
}  // namespace rgbdmap
