// The avoidance rule end to end on the synthetic room: a level camera drives straight at the room's +x side;
// its depth frames (ground-truth poses) go into an OctoMap, a slice is projected from the octree at every
// step, and the commands must switch from forward to turning as the obstacle ahead comes within the safety
// distance, then to backing off when it is very close.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <octomap/OcTree.h>

#include "avoidance_test_util.hpp"
#include "rgbdmap/client/avoidance.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

constexpr double kSliceRes = 0.05;
constexpr double kCameraHeight = 0.5;               ///< world z of the camera (a small ground robot)
constexpr double kBandLow = -0.4, kBandHigh = 0.5;  ///< slice height band relative to the camera

/// Level camera at world (x, 0, kCameraHeight) looking along world +x (camera x = world -y, y = world -z).
SE3 worldCamera(double x) {
  SE3 T = SE3::Identity();
  T.linear() << 0, 0, 1,  //
      -1, 0, 0,           //
      0, -1, 0;
  T.translation() = Vec3(x, 0.0, kCameraHeight);
  return T;
}

/// Exact distance ahead (along +x) to the first surface in the corridor (|y| <= width / 2) and height band.
double trueCorridorDistance(const SyntheticScene& scene, double x, double width_m) {
  double closest = std::numeric_limits<double>::infinity();
  for (double y = -width_m / 2; y <= width_m / 2 + 1e-9; y += 0.025)
    for (double h = kBandLow + 0.05; h <= kBandHigh + 1e-9; h += 0.05)
      if (auto hit = scene.castRay(Vec3(x, y, kCameraHeight + h), Vec3::UnitX()))
        closest = std::min(closest, hit->t);
  return closest;
}

/// Depth pixels (every 4th) into the octree, in the map frame; rays clear free space up to 4 m.
void insertFrame(const RgbdFrame& frame, const PinholeCamera& camera, const SE3& T_map_cam,
                 octomap::OcTree* tree) {
  octomap::Pointcloud cloud;
  for (int v = 0; v < frame.depth.rows; v += 4)
    for (int u = 0; u < frame.depth.cols; u += 4) {
      const double z = frame.depthMetres(u, v);
      if (z <= 0.0) continue;
      const Vec3 p = T_map_cam * camera.backProject(Eigen::Vector2d(u, v), z);
      cloud.push_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
    }
  const Vec3 o = T_map_cam.translation();
  tree->insertPointCloud(cloud, octomap::point3d(o.x(), o.y(), o.z()), 4.0);
}

/// A robot-centred 4.4 m slice (2.2 m ahead, beyond the lookahead) projected from the octree: leaves with
/// their centre in the height band; occupied wins over free, anything else unknown.
msg::OccupancySlice projectSlice(const octomap::OcTree& tree, const SE3& T_map_cam, const Vec3& up,
                                 double now_s) {
  msg::OccupancySlice s =
      testing::robotCentredSlice(T_map_cam, 4.4, kSliceRes, msg::OccupancySlice::kUnknown);
  s.header.utime = static_cast<int64_t>(std::llround(now_s * 1e6));
  const double cam_height = T_map_cam.translation().dot(up);
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    const Vec3 c(it.getX(), it.getY(), it.getZ());
    const double h = c.dot(up) - cam_height;
    if (h < kBandLow || h > kBandHigh) continue;
    const bool occupied = tree.isNodeOccupied(*it);
    const int n = std::max(1, static_cast<int>(std::lround(it.getSize() / kSliceRes)));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) {
          const Vec3 p = c + kSliceRes * Vec3(i - (n - 1) / 2.0, j - (n - 1) / 2.0, k - (n - 1) / 2.0);
          const Vec3 g = s.T_map_grid.inverse() * p;
          const int col = static_cast<int>(std::floor(g.x() / kSliceRes)),
                    row = static_cast<int>(std::floor(g.y() / kSliceRes));
          if (col < 0 || row < 0 || col >= s.width || row >= s.height) continue;
          int8_t& cell = s.cells[static_cast<size_t>(row) * s.width + col];
          if (occupied)
            cell = msg::OccupancySlice::kOccupied;
          else if (cell == msg::OccupancySlice::kUnknown)
            cell = msg::OccupancySlice::kFree;
        }
  }
  return s;
}

RGBDMAP_TEST_TIER("AvoidanceE2E.*", "e2e");
TEST(AvoidanceE2E, CommandsReactToTheObstacleAheadInTheSyntheticRoom) {
  SynthConfig cfg;
  cfg.frames = 2;
  cfg.camera = CameraIntrinsics{262.5, 262.5, 159.5, 119.5, 320, 240, {0, 0, 0, 0, 0}, 5000.0, 0.0};
  auto scene = SyntheticScene::build(cfg);
  ASSERT_TRUE(scene) << scene.error();
  const PinholeCamera camera(cfg.camera);
  const AvoidanceConfig acfg;  // defaults: safety 0.8 m, emergency 0.35 m, corridor 0.5 m
  AvoidanceController controller(acfg);

  // Start where the corridor is clear for 1.52 m (the obstacle off the voxel boundaries of the map, whose
  // origin is the first camera's: the default mount has no offset).
  double x = 0.0;
  x += trueCorridorDistance(*scene, x, acfg.corridor_width_m) - 1.52;
  ASSERT_NEAR(trueCorridorDistance(*scene, x, acfg.corridor_width_m), 1.52, 1e-6);
  // The map frame is the base frame of the first keyframe (the default mount: a level, forward camera).
  const SE3 T_map_world = (worldCamera(x) * defaultT_base_camera().inverse()).inverse();
  const Vec3 up_map = T_map_world.linear() * Vec3::UnitZ();
  ASSERT_TRUE(up_map.isApprox(acfg.up_in_map, 1e-12)) << "a level first camera: the map is z-up";

  octomap::OcTree tree(kSliceRes);
  bool turned = false;
  double t = 100.0, true_at_turn = NAN;
  AvoidanceDecision d;
  for (int step = 0;; ++step, x += 0.05, t += 0.1) {
    const double truth = trueCorridorDistance(*scene, x, acfg.corridor_width_m);
    if (truth < 0.25) break;
    const SE3 T_map_cam = T_map_world * worldCamera(x);
    insertFrame(scene->render(worldCamera(x), step), camera, T_map_cam, &tree);
    d = controller.update(projectSlice(tree, T_map_cam, up_map, t), T_map_cam, t);
    ASSERT_FALSE(d.stopped) << d.reason;
    if (truth <= 1.5) {  // seen, and quantised to the voxels: at most one voxel nearer than the truth
      EXPECT_LE(d.closest_obstacle_m, truth + 0.02) << "step " << step;
      EXPECT_GE(d.closest_obstacle_m, truth - kSliceRes - 0.02) << "step " << step;
    }
    if (truth > acfg.safety_distance_m + 0.1) {
      EXPECT_EQ(d.state, AvoidanceState::kForward) << "step " << step << ", obstacle " << truth << " m ahead";
      EXPECT_GT(controller.command(d, "robot0").linear_mps.x(), 0.0);
      EXPECT_EQ(controller.command(d, "robot0").angular_radps.z(), 0.0);
    }
    if (!turned && d.state != AvoidanceState::kForward) {
      turned = true;
      true_at_turn = truth;
      EXPECT_EQ(d.state, AvoidanceState::kTurnLeft) << "the first reaction is turning left";
      EXPECT_GT(controller.command(d, "robot0").angular_radps.z(), 0.0) << "counter-clockwise = left";
    }
  }
  ASSERT_TRUE(turned) << "never reacted to the obstacle ahead";
  EXPECT_NEAR(true_at_turn, acfg.safety_distance_m, 0.1)
      << "turned with the obstacle at " << true_at_turn << " m";
  EXPECT_EQ(d.state, AvoidanceState::kBackRight) << "very close at the end: back off";
  EXPECT_LT(controller.command(d, "robot0").linear_mps.x(), 0.0);
}

}  // namespace
}  // namespace rgbdmap
