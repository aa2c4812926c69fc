// Occupancy map: geometry of the synthetic room, kept clouds spilled to a file, input checks, the clouds of
// keyframes.
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "occupancy_map_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::countLeaves;
using testing::expectSameLeaves;
using testing::insertAll;
using testing::LeafCounts;
using testing::makeSynthKeyframes;
using testing::octreeHitDistance;
using testing::testConfig;

TEST(OccupancyMap, SyntheticRoomMatchesGeometry) {
  const OccupancyMapConfig config = testConfig();
  const auto& kf = makeSynthKeyframes("loop", 12);
  OccupancyMap map(config);
  insertAll(&map, kf, 0);
  const double res = config.resolution_m;
  size_t occupied = 0, near_surface = 0;
  map.read(0, [&](const octomap::OcTree& tree) {
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
      if (!tree.isNodeOccupied(*it)) continue;
      ++occupied;
      const octomap::point3d c = it.getCoordinate();
      if (kf.scene->distanceToSurface(Vec3(c.x(), c.y(), c.z())) <= 2.0 * res) ++near_surface;
    }
  });
  ASSERT_GT(occupied, 5000u);
  EXPECT_GE(double(near_surface) / occupied, 0.95) << near_surface << " of " << occupied;

  // Points on true camera rays well before the surface they hit are free; points outside the room unknown.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  size_t samples = 0, free_ok = 0, outside = 0, outside_unknown = 0;
  map.read(0, [&](const octomap::OcTree& tree) {
    while (samples < 2000) {
      const size_t k = rng() % kf.T_world_cam.size();
      const SE3& T = kf.T_world_cam[k];
      const Vec3 dir = T.linear() * Vec3((u01(rng) - 0.5) * 1.1, (u01(rng) - 0.5) * 0.8, 1.0);
      const auto hit = kf.scene->castRay(T.translation(), dir);
      if (!hit) continue;
      const double range = hit->t * dir.norm();
      const double s = config.min_range_m + 0.1 + u01(rng) * (std::min(range, config.max_range_m) - 0.5);
      const Vec3 p = T.translation() + dir.normalized() * s;
      if (s > range - 3 * res || kf.scene->distanceToSurface(p) < 2 * res) continue;
      ++samples;
      const octomap::OcTreeNode* node = tree.search(p.x(), p.y(), p.z());
      if (node && !tree.isNodeOccupied(node)) ++free_ok;
    }
    const auto& room = kf.scene->room();
    for (int i = 0; i < 2000; ++i) {
      const Vec3 p(room.min().x() - 0.15 - u01(rng), room.min().y() + u01(rng) * room.sizes().y(),
                   u01(rng) * 2.5);
      ++outside;
      if (!tree.search(p.x(), p.y(), p.z())) ++outside_unknown;
    }
  });
  EXPECT_GE(double(free_ok) / samples, 0.95) << free_ok << " of " << samples;
  EXPECT_GE(double(outside_unknown) / outside, 0.95) << outside_unknown << " of " << outside;
  const OccupancyMapStats s = map.stats();
  EXPECT_EQ(s.maps, 1);
  EXPECT_EQ(s.keyframes, 12u);
  EXPECT_EQ(s.occupied_leaves, occupied);
  EXPECT_GT(s.tree_memory_bytes, 0u);
  EXPECT_GT(s.clouds_memory_bytes, 0u);
}

TEST(OccupancyMap, SpilledCloudsRebuildTheSameTreeAndExportTheSameClouds) {
  const auto& kf = makeSynthKeyframes("sweep", 12);
  char dir[] = "/tmp/rgbdmap_spill_XXXXXX";
  ASSERT_NE(mkdtemp(dir), nullptr);
  OccupancyMapConfig spilled_config = testConfig();
  spilled_config.clouds_in_memory = 3;
  spilled_config.spill_dir = dir;
  OccupancyMap spilled(spilled_config), plain(testConfig());
  ASSERT_EQ(spilled.spillError(), "");
  insertAll(&spilled, kf, 0);
  insertAll(&plain, kf, 0);
  OccupancyMapStats s = spilled.stats();
  EXPECT_EQ(s.clouds_spilled, 9u);
  EXPECT_GT(s.spill_file_bytes, 0u);
  EXPECT_LT(s.clouds_memory_bytes, plain.stats().clouds_memory_bytes / 3);
  EXPECT_EQ(plain.stats().clouds_spilled, 0u);
  const auto compare = [&] {
    spilled.read(0, [&](const octomap::OcTree& a) {
      plain.read(0, [&](const octomap::OcTree& b) { EXPECT_GT(expectSameLeaves(a, b), 10000u); });
    });
  };
  // A loop correction of three keyframes (a partial rebuild), then of all (a whole one).
  for (const size_t first : {size_t{9}, size_t{0}}) {
    std::map<int64_t, std::pair<int, SE3>> moved;
    for (size_t i = first; i < kf.clouds.size(); ++i)
      moved[int64_t(i)] = {0, Eigen::Translation3d(0.0, 0.2, 0.0) * kf.T_world_cam[i]};
    EXPECT_TRUE(spilled.updatePoses(moved));
    EXPECT_TRUE(plain.updatePoses(moved));
    ASSERT_TRUE(spilled.waitIdle(60.0));
    ASSERT_TRUE(plain.waitIdle(60.0));
    compare();
  }
  EXPECT_EQ(spilled.stats().partial_rebuilds, 1u);
  EXPECT_EQ(spilled.stats().rebuilds, 2u);
  const auto a = spilled.keptClouds(), b = plain.keptClouds();
  ASSERT_EQ(a.size(), kf.clouds.size());
  ASSERT_EQ(b.size(), kf.clouds.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].cloud->keyframe_id, b[i].cloud->keyframe_id);
    EXPECT_EQ(a[i].cloud->points_cam, b[i].cloud->points_cam) << "keyframe " << i;
    EXPECT_EQ(a[i].cloud->colors_rgb, b[i].cloud->colors_rgb) << "keyframe " << i;
    EXPECT_TRUE(a[i].T_map_cam.isApprox(b[i].T_map_cam, 0.0));
  }
  EXPECT_EQ(spilled.stats().spill_failures, 0u);
  EXPECT_EQ(rmdir(dir), 0) << "the spill file has no name: nothing is left in the directory";
}

TEST(OccupancyMap, WithoutASpillFileEveryCloudStaysInRam) {
  const auto& kf = makeSynthKeyframes("sweep", 12);
  OccupancyMapConfig config = testConfig();
  config.clouds_in_memory = 3;
  config.spill_dir = "/nonexistent/rgbdmap_spill";
  OccupancyMap map(config);
  EXPECT_NE(map.spillError().find("/nonexistent/rgbdmap_spill"), std::string::npos) << map.spillError();
  insertAll(&map, kf, 0);
  EXPECT_EQ(map.stats().clouds_spilled, 0u);
  EXPECT_EQ(map.keptClouds().size(), kf.clouds.size());
}

TEST(OccupancyMap, RejectsBadInput) {
  const OccupancyMapConfig config = testConfig();
  OccupancyMap map(config);
  KeyframeCloud cloud;
  cloud.keyframe_id = 1;
  cloud.points_cam = {Eigen::Vector3f(0, 0, 1)};
  SE3 bad = SE3::Identity();
  bad(0, 3) = std::nan("");
  EXPECT_FALSE(map.insert(cloud, 0, bad).ok());
  EXPECT_TRUE(map.insert(cloud, 0, SE3::Identity()).ok());
  const Status dup = map.insert(cloud, 0, SE3::Identity());
  EXPECT_FALSE(dup.ok());
  EXPECT_NE(dup.error().find("already"), std::string::npos);
  cloud.keyframe_id = 2;
  cloud.points_cam[0].x() = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(map.insert(cloud, 0, SE3::Identity()).ok());
  EXPECT_FALSE(map.updatePoses({{1, {0, bad}}, {99, {0, SE3::Identity()}}}));  // ignored
  EXPECT_FALSE(map.read(7, [](const octomap::OcTree&) {}));

  OccupancyMapConfig wrong;
  wrong.resolution_m = -1;
  wrong.prob_hit = 0.3;
  wrong.max_range_m = std::nan("");
  const std::string why = wrong.validate();
  EXPECT_NE(why.find("resolution_m"), std::string::npos);
  EXPECT_NE(why.find("prob_hit"), std::string::npos);
  EXPECT_NE(why.find("max_range_m"), std::string::npos);
  EXPECT_EQ(OccupancyMapConfig{}.validate(), "");

  const PinholeCamera camera{CameraIntrinsics{}};
  EXPECT_FALSE(makeKeyframeCloud(1, cv::Mat(480, 640, CV_32FC1), 5000, cv::Mat(), camera, config).ok());
  EXPECT_FALSE(makeKeyframeCloud(1, cv::Mat(240, 320, CV_16UC1), 5000, cv::Mat(), camera, config).ok());
  EXPECT_FALSE(makeKeyframeCloud(1, cv::Mat::zeros(480, 640, CV_16UC1), 0.0, cv::Mat(), camera, config).ok());
  EXPECT_FALSE(makeKeyframeCloud(1, cv::Mat::zeros(480, 640, CV_16UC1), 5000, cv::Mat(480, 640, CV_8UC1),
                                 camera, config)
                   .ok());
}

TEST(OccupancyMap, KeyframeCloudKeepsRangeAndReducesPoints) {
  OccupancyMapConfig config = testConfig();
  CameraIntrinsics k;
  k.distortion = {0, 0, 0, 0, 0};
  const PinholeCamera camera(k);
  cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(2.0 * 5000));  // a plane 2 m away
  depth(cv::Rect(0, 0, 640, 100)).setTo(0);                   // missing
  depth(cv::Rect(0, 100, 640, 20)).setTo(0.1 * 5000);         // closer than min range
  depth(cv::Rect(0, 120, 640, 20)).setTo(9.0 * 5000);         // beyond max range
  const cv::Mat bgr(480, 640, CV_8UC3, cv::Scalar(10, 20, 30));
  auto cloud = makeKeyframeCloud(3, depth, 5000, bgr, camera, config);
  ASSERT_TRUE(cloud.ok()) << cloud.error();
  EXPECT_EQ(cloud->keyframe_id, 3);
  ASSERT_EQ(cloud->colors_rgb.size(), cloud->points_cam.size());
  size_t far = 0;
  for (size_t i = 0; i < cloud->points_cam.size(); ++i) {
    const Eigen::Vector3f& p = cloud->points_cam[i];
    EXPECT_GE(p.norm(), config.min_range_m);
    EXPECT_LE(p.norm(), config.max_range_m + config.resolution_m + 1e-3);
    if (p.norm() > config.max_range_m) ++far;
    EXPECT_EQ(cloud->colors_rgb[i][0], 30);  // RGB order
  }
  EXPECT_GT(far, 0u);
  // One point per 2.5 cm cube: the 2 m plane (~2.2 x 1.2 m visible) holds a few thousand, not 250k pixels.
  EXPECT_GT(cloud->points_cam.size(), 2000u);
  EXPECT_LT(cloud->points_cam.size(), 8000u);
}

}  // namespace
}  // namespace rgbdmap
