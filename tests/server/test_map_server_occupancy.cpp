// The occupancy octree inside the mapping server: a synthetic run over memq:// builds the room,
// robots receive slices and the map stream, an optimisation rebuilds the map, the written files read back,
// and a restart re-inserts the stored keyframes.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "rgbdmap/export/point_cloud_export.hpp"
#include "rgbdmap/export/slice_export.hpp"
#include "rgbdmap/link/robot_runner.hpp"
#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::kLoopFrames;
using testing::loopSegment;
using testing::OdometrySegment;
using testing::ScriptedRobot;

std::string occDir(const std::string& name) { return testing::freshDir("occ_" + name); }

MapServerConfig testConfig(const std::string& dir) {
  MapServerConfig config = testing::serverTestConfig(dir, {"robot0"});
  config.map_stream_period_s = 0.2;  // several stream messages within the test
  config.slice_period_s = 0.0;       // a slice after every keyframe
  // The synthetic loop's odometry drifts ~1 cm, so its loop closure moves keyframes by less than the default
  // 3 cm rebuild threshold; a 5 mm threshold makes the optimisation's correction rebuild the map.
  config.occupancy.rebuild_translation_m = 0.005;
  config.occupancy.rebuild_rotation_rad = 0.005;
  return config;
}

using OccHarness = testing::ServerHarness;

/// The synthetic world pose of the map frame: the map frame is the first keyframe's odometry frame, which
/// the server keeps fixed, so world <- map = gt(first keyframe) * (T_map_kf of node 0)^-1.
SE3 worldFromMap(const OdometrySegment& seg, const MapServer& server) {
  const std::vector<ServerKeyframe> kfs = server.keyframes();
  EXPECT_FALSE(kfs.empty());
  const StampedPose* best = &seg.gt.front();
  for (const StampedPose& p : seg.gt)
    if (std::abs(p.timestamp - kfs.front().timestamp) < std::abs(best->timestamp - kfs.front().timestamp))
      best = &p;
  return best->T_world_cam * kfs.front().T_map_kf.inverse();
}

/// Share of the occupied leaves whose centre lies within 2 leaf sizes of a true surface of the room.
double nearSurfaceFraction(const octomap::OcTree& tree, const SyntheticScene& scene, const SE3& T_world_map,
                           size_t* occupied_out) {
  size_t occupied = 0, near = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    ++occupied;
    const octomap::point3d c = it.getCoordinate();
    if (scene.distanceToSurface(T_world_map * Vec3(c.x(), c.y(), c.z())) <= 2.0 * tree.getResolution())
      ++near;
  }
  if (occupied_out) *occupied_out = occupied;
  return occupied ? double(near) / double(occupied) : 0.0;
}

const SyntheticScene& loopScene() {
  static const SyntheticScene scene = [] {
    SynthConfig cfg;
    cfg.scene = "loop";
    cfg.frames = kLoopFrames;
    return std::move(SyntheticScene::build(cfg).value());
  }();
  return scene;
}

size_t countOccupied(const octomap::OcTree& tree) {
  size_t n = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) n += tree.isNodeOccupied(*it);
  return n;
}

/// Occupied volume in leaf-size cubes (independent of how the tree is pruned).
double occupiedCells(const octomap::OcTree& tree) {
  double n = 0;
  const double res = tree.getResolution();
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it)
    if (tree.isNodeOccupied(*it)) n += std::pow(it.getSize() / res, 3);
  return n;
}

RGBDMAP_TEST_TIER("MapServerOccupancy.*", "e2e");
TEST(MapServerOccupancy, SyntheticLoopBuildsTheRoomSendsSlicesAndStreamsAndWritesFiles) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GT(seg.keyframes.size(), 20u);
  OccHarness h(testConfig(occDir("loop")));
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, seg, 0, seg.keyframes.size());
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.map_keyframes, seg.keyframes.size());
  EXPECT_GE(s.optimizations, 1);
  EXPECT_GE(s.map_rebuilds, 1u) << "the loop closure's optimisation must rebuild the map";
  EXPECT_GT(s.map_occupied_leaves, 1000u);
  EXPECT_GT(s.map_tree_memory_bytes, 0u);
  EXPECT_EQ(s.slices_sent, seg.keyframes.size()) << "slice_period_s 0: one slice per keyframe";
  std::printf(
      "[ measured ] synthetic loop, %zu keyframes: ingest median %.1f ms, octree insert median %.1f ms "
      "(map worker), %zu leaves (%zu occupied), tree %.2f MB, clouds %.2f MB, %llu rebuilds (last %.0f ms), "
      "%llu slices, %llu map updates (%.1f KB)\n",
      seg.keyframes.size(), s.ingest_ms_median, s.map_insert_ms_median, s.map_leaves, s.map_occupied_leaves,
      s.map_tree_memory_bytes / 1e6, s.map_clouds_memory_bytes / 1e6,
      static_cast<unsigned long long>(s.map_rebuilds), s.map_last_rebuild_ms,
      static_cast<unsigned long long>(s.slices_sent), static_cast<unsigned long long>(s.map_updates_sent),
      s.map_bytes_sent / 1e3);

  // The robot's slices: the last one is around its last keyframe and sees walls and free floor space.
  EXPECT_EQ(robot.slicesReceived(), static_cast<int>(seg.keyframes.size()));
  const auto slice = robot.lastSlice();
  ASSERT_TRUE(slice);
  EXPECT_EQ(slice->robot_id, "robot0");
  const auto count = [&](int8_t v) { return std::count(slice->cells.begin(), slice->cells.end(), v); };
  EXPECT_GT(count(msg::OccupancySlice::kOccupied), 50);
  EXPECT_GT(count(msg::OccupancySlice::kFree), 500);

  // The written files read back; the octree's occupied cells lie on the room's surfaces.
  const std::string out = occDir("loop_out");
  const Status written = h.server->writeMapOutputs(out);
  ASSERT_TRUE(written) << written.error();
  auto bt = readMapFile(out + "/map.bt");
  ASSERT_TRUE(bt) << bt.error();
  auto ot = readMapFile(out + "/map.ot");
  ASSERT_TRUE(ot) << ot.error();
  size_t occupied = 0;
  const SE3 T_world_map = worldFromMap(seg, *h.server);
  const double near = nearSurfaceFraction(**bt, loopScene(), T_world_map, &occupied);
  std::printf("[ measured ] map.bt: %zu occupied leaves, %.1f%% within 2 leaves of a true surface\n",
              occupied, 100.0 * near);
  EXPECT_EQ(occupied, s.map_occupied_leaves);
  EXPECT_EQ(countOccupied(**ot), occupied);
  EXPECT_GE(near, 0.9);
  auto ply = readPly(out + "/map.ply");
  ASSERT_TRUE(ply) << ply.error();
  ASSERT_GT(ply->size(), 10000u);
  size_t ply_near = 0;
  for (const ColoredPoint& p : *ply)
    ply_near += loopScene().distanceToSurface(T_world_map * p.p.cast<double>()) <= 0.03;
  EXPECT_GE(double(ply_near) / double(ply->size()), 0.9) << ply_near << " of " << ply->size();
  auto read_slice = readSlice(out + "/slice_robot0.yaml");
  ASSERT_TRUE(read_slice) << read_slice.error();
  EXPECT_EQ(read_slice->cells, slice->cells) << "the file holds the robot's last slice";
  EXPECT_GT(std::filesystem::file_size(out + "/map.png"), 1000u);

  // The map stream converges to the server's tree (full first and after rebuilds, partial in between).
  const double cells = occupiedCells(**bt);
  double robot_cells = 0;
  EXPECT_TRUE(robot.waitMap(
      [&](const octomap::OcTree& t) { return (robot_cells = occupiedCells(t)) == cells; }, 10.0))
      << "the streamed map never matched map.bt: occupied cells " << robot_cells << " vs " << cells;
  const auto seen = robot.mapStream();
  EXPECT_GE(seen.full, 1);
  EXPECT_EQ(seen.failed, 0);
  EXPECT_GT(seen.bytes, 0u);
}

TEST(MapServerOccupancy, RestartReinsertsTheStoredKeyframes) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  const std::string dir = occDir("restart");
  const size_t half = seg.keyframes.size() / 2;
  OccHarness h(testConfig(dir));
  size_t occupied_before = 0;
  {
    ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
    testing::driveRobot(*h.server, robot, seg, 0, half);
    occupied_before = h.server->stats().map_occupied_leaves;
  }
  h.server->stop();
  h.server.reset();
  h.start(testConfig(dir));
  ASSERT_TRUE(h.server->waitIdle(60.0));
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.map_keyframes, half) << "every stored keyframe re-inserted from the store";
  std::printf("[ measured ] restart: %zu keyframes re-inserted, occupied leaves %zu before, %zu after\n",
              s.map_keyframes, occupied_before, s.map_occupied_leaves);
  EXPECT_NEAR(double(s.map_occupied_leaves), double(occupied_before), 0.05 * double(occupied_before));
  EXPECT_EQ(s.slices_sent, 0u) << "restored keyframes send no slices";
  // The robot goes on; its new keyframes join the restored map and get slices.
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, seg, half, seg.keyframes.size());
  EXPECT_EQ(h.server->stats().map_keyframes, seg.keyframes.size());
  EXPECT_GE(robot.slicesReceived(), 1);
  const std::string out = occDir("restart_out");
  ASSERT_TRUE(h.server->writeMapOutputs(out));
  auto bt = readMapFile(out + "/map.bt");
  ASSERT_TRUE(bt) << bt.error();
  EXPECT_GE(nearSurfaceFraction(**bt, loopScene(), worldFromMap(seg, *h.server), nullptr), 0.9);
}

RGBDMAP_TEST_TIER("MapServerOccupancy.OffMeansNoOctreeNoSlicesAndAClearErrorForFiles", "e2e sanitize");
TEST(MapServerOccupancy, OffMeansNoOctreeNoSlicesAndAClearErrorForFiles) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, 60);
  MapServerConfig config = testConfig(occDir("off"));
  config.occupancy_enabled = false;
  OccHarness h(config);
  ScriptedRobot robot(*h.transport, "robot0", rgbdmap::testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, seg, 0, 3);
  const MapServerStats s = h.server->stats();
  EXPECT_EQ(s.keyframes, 3);
  EXPECT_EQ(s.map_keyframes, 0u);
  EXPECT_EQ(robot.slicesReceived(), 0);
  const Status written = h.server->writeMapOutputs(occDir("off_out"));
  ASSERT_FALSE(written);
  EXPECT_NE(written.error().find("occupancy"), std::string::npos) << written.error();
}

RGBDMAP_TEST_TIER("MapServerOccupancy.InvalidOccupancyConfigurationIsRefusedAtStart", "e2e sanitize");
TEST(MapServerOccupancy, InvalidOccupancyConfigurationIsRefusedAtStart) {
  MapServerConfig config = testConfig(occDir("badconfig"));
  config.occupancy.resolution_m = -1.0;
  config.slice.z_min_m = std::nan("");
  config.map_stream_period_s = -2.0;
  auto transport = std::move(transport::makeTransport("memq://").value());
  MapServer server(config, *transport, msg::KeyStore::openMode());
  const Status s = server.start();
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().find("occupancy"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("slice"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("map.stream_period_s"), std::string::npos) << s.error();
}

/// A real robot (RobotLink + runRobot with avoidance on) against the real server on the synthetic loop: it
/// receives slices, decides on them every frame, publishes its commands, and the obstacles it reports are
/// real surfaces of the room.
TEST(MapServerOccupancy, RobotRunAvoidsOnTheServersSlices) {
  SynthConfig sc;
  sc.scene = "loop";
  sc.frames = 120;
  sc.camera = {262.5, 262.5, 159.5, 119.5, 320, 240, {0, 0, 0, 0, 0}, 5000.0, 0.0};  // quarter size: fast
  const std::string data = occDir("robot_run_data");
  ASSERT_TRUE(writeSyntheticSequence(sc, data));
  const auto scene = SyntheticScene::build(sc);
  ASSERT_TRUE(scene) << scene.error();
  DatasetOptions dataset_options;
  dataset_options.depth_scale = sc.camera.depth_scale;
  dataset_options.expected_width = sc.camera.width;
  dataset_options.expected_height = sc.camera.height;
  auto dataset = TumDataset::open(data, dataset_options);
  ASSERT_TRUE(dataset) << dataset.error();

  OccHarness h(testConfig(occDir("robot_run")));
  RobotLinkOptions lo;
  lo.robot_id = "robot0";
  lo.key = rgbdmap::testing::testKey(1);
  lo.camera = sc.camera;
  RobotLink link(*h.transport, lo);
  ASSERT_TRUE(link.start());
  RobotRunOptions ro;
  ro.realtime = true;  // slices must keep up with the frames (max_slice_age_s)
  ro.final_wait_s = 20.0;
  ro.avoidance = AvoidanceConfig{};
  const RobotRunResult r = runRobot(*dataset, sc.camera, OdometryConfig{}, link, ro);
  link.stop();

  ASSERT_EQ(r.frames, sc.frames);
  ASSERT_TRUE(r.avoidance);
  const AvoidanceSummary& a = *r.avoidance;
  std::printf(
      "[ measured ] robot run with avoidance, %d frames: forward %d, turn-left %d, back-right %d, stopped "
      "%d; "
      "%llu slices received, %d commands published\n",
      r.frames, a.forward, a.turn_left, a.back_right, a.stopped,
      static_cast<unsigned long long>(r.link.slices_received), a.commands_published);
  EXPECT_EQ(a.decisions.size(), static_cast<size_t>(r.frames));
  EXPECT_EQ(a.forward + a.turn_left + a.back_right + a.stopped, r.frames);
  EXPECT_EQ(a.commands_published, r.frames);
  EXPECT_EQ(r.link.commands_sent, static_cast<uint64_t>(r.frames));
  EXPECT_EQ(r.link.commands_received, 0u) << "the robot's own commands are not server commands";
  EXPECT_EQ(r.link.messages_rejected, 0u) << "the echo of its own commands is not a rejection";
  EXPECT_GE(r.link.slices_received, 3u);
  EXPECT_GT(a.forward + a.turn_left + a.back_right, r.frames / 2) << "most frames decided on a fresh slice";
  // Every obstacle it reported is a real surface: some point of the corridor's cross-section at that
  // distance (within the slice's height band, plus a cell for quantisation) lies within 10 cm of the room's
  // geometry, seen from the ground-truth pose. "Up" is the map's up (z: the map is z-up), as in
  // the slice.
  const SE3 T_world_map = scene->trajectory().front().T_world_cam * r.live.front().T_world_cam.inverse();
  const Vec3 up = T_world_map.linear() * Vec3(0, 0, 1);
  int finite = 0, real = 0;
  for (const AvoidanceRecord& d : a.decisions) {
    if (d.stopped || !std::isfinite(d.closest_obstacle_m)) continue;
    ++finite;
    const StampedPose* gt = &scene->trajectory().front();
    for (const StampedPose& p : scene->trajectory())
      if (std::abs(p.timestamp - d.timestamp) < std::abs(gt->timestamp - d.timestamp)) gt = &p;
    Vec3 forward = gt->T_world_cam.linear().col(2);
    forward = (forward - forward.dot(up) * up).normalized();
    const Vec3 left = up.cross(forward);
    const Vec3 centre = gt->T_world_cam.translation() + (d.closest_obstacle_m + 0.025) * forward;
    double nearest = 1e9;
    for (double l = -0.3; l <= 0.3 + 1e-9; l += 0.05)
      for (double z = -0.35; z <= 0.35 + 1e-9; z += 0.05)
        nearest = std::min(nearest, scene->distanceToSurface(centre + l * left + z * up));
    real += nearest <= 0.1;
  }
  std::printf("[ measured ] %d decisions saw an obstacle in the corridor, %d of them on a true surface\n",
              finite, real);
  EXPECT_GT(finite, 0) << "the loop passes walls and furniture: some obstacle must be seen ahead";
  EXPECT_GE(real, finite * 9 / 10);
}

}  // namespace
}  // namespace rgbdmap
