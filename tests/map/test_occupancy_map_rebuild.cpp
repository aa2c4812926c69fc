// Occupancy map rebuilds: after pose corrections (whole and partial, within the held budget or not), readers
// during rebuilds, inserts during rebuilds, merging map ids.
#include <atomic>
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

TEST(OccupancyMap, RebuildAfterPoseCorrectionMovesTheWall) {
  const OccupancyMapConfig config = testConfig();
  const auto& kf = makeSynthKeyframes("sweep", 12);
  OccupancyMap map(config);
  insertAll(&map, kf, 0);
  const SE3& T_mid = kf.T_world_cam[6];
  const Vec3 forward = T_mid.linear().col(2);
  double before = -1;
  map.read(0, [&](const octomap::OcTree& t) { before = octreeHitDistance(t, T_mid.translation(), forward); });
  const auto truth = kf.scene->castRay(T_mid.translation(), forward);
  ASSERT_TRUE(truth.has_value());
  EXPECT_NEAR(before, truth->t * forward.norm(), 2 * config.resolution_m);

  // Below the thresholds nothing is rebuilt.
  std::map<int64_t, std::pair<int, SE3>> small;
  for (size_t i = 0; i < kf.clouds.size(); ++i)
    small[int64_t(i)] = {0, Eigen::Translation3d(0.01, 0, 0) * kf.T_world_cam[i]};
  EXPECT_FALSE(map.updatePoses(small));

  const uint64_t revision = map.revision(0);
  const Vec3 shift = 0.3 * Vec3(forward.x(), forward.y(), 0).normalized();
  std::map<int64_t, std::pair<int, SE3>> moved;
  for (size_t i = 0; i < kf.clouds.size(); ++i)
    moved[int64_t(i)] = {0, Eigen::Translation3d(shift) * kf.T_world_cam[i]};
  EXPECT_TRUE(map.updatePoses(moved));
  ASSERT_TRUE(map.waitIdle(30.0));
  double after = -1;
  map.read(0, [&](const octomap::OcTree& t) { after = octreeHitDistance(t, T_mid.translation(), forward); });
  EXPECT_NEAR(after - before, shift.dot(forward), 2 * config.resolution_m);
  EXPECT_GT(map.revision(0), revision);
  EXPECT_EQ(map.stats().rebuilds, 1u);
  EXPECT_GT(map.stats().last_rebuild_ms, 0.0);
}

TEST(OccupancyMap, APartialRebuildRecomputesOnlyWhereKeyframesMovedAndEqualsAWholeRebuild) {
  const OccupancyMapConfig config = testConfig();
  const auto& kf = makeSynthKeyframes("loop", 16);
  // The room twice, 20 m apart: keyframes 0-15 and 100-115 (the second copy).
  const SE3 far(Eigen::Translation3d(20.0, 0.0, 0.0));
  std::vector<std::pair<KeyframeCloud, SE3>> all;
  for (size_t i = 0; i < kf.clouds.size(); ++i) all.push_back({kf.clouds[i], kf.T_world_cam[i]});
  for (size_t i = 0; i < kf.clouds.size(); ++i) {
    KeyframeCloud c = kf.clouds[i];
    c.keyframe_id = 100 + static_cast<int64_t>(i);
    all.push_back({std::move(c), far * kf.T_world_cam[i]});
  }
  OccupancyMap map(config);
  for (const auto& [cloud, T] : all) ASSERT_TRUE(map.insert(cloud, 0, T).ok());

  // A loop correction of the second copy's last three keyframes (0.2 m and 3 deg) while every other
  // keyframe moves 1 cm, below the thresholds: those stay where they are integrated.
  const SE3 correction = Eigen::Translation3d(0.1, 0.17, 0.0) * Eigen::AngleAxisd(0.05, Vec3::UnitZ());
  std::map<int64_t, std::pair<int, SE3>> poses;
  std::vector<SE3> expected;  // where each keyframe is integrated after the rebuild
  for (const auto& [cloud, T] : all) {
    const bool moved = cloud.keyframe_id >= 113;
    poses[cloud.keyframe_id] = {
        0, moved ? SE3(far * correction * far.inverse() * T) : SE3(Eigen::Translation3d(0.0, 0.01, 0.0) * T)};
    expected.push_back(moved ? poses[cloud.keyframe_id].second : T);
  }
  const uint64_t revision = map.revision(0);
  EXPECT_TRUE(map.updatePoses(poses));
  ASSERT_TRUE(map.waitIdle(60.0));
  const OccupancyMapStats s = map.stats();
  EXPECT_EQ(s.rebuilds, 1u);
  EXPECT_EQ(s.partial_rebuilds, 1u);
  // The three moved keyframes are cast twice (old and new poses) plus at most the second copy's other 13:
  // nothing of the first room, 20 m away.
  EXPECT_GE(s.last_rebuild_keyframes, 6u);
  EXPECT_LE(s.last_rebuild_keyframes, 19u);
  EXPECT_GT(map.revision(0), revision);

  // The same tree as integrating every cloud afresh where the map has it now.
  OccupancyMap reference(config);
  for (size_t i = 0; i < all.size(); ++i) ASSERT_TRUE(reference.insert(all[i].first, 0, expected[i]).ok());
  size_t leaves = 0;
  map.read(0, [&](const octomap::OcTree& t) {
    reference.read(0, [&](const octomap::OcTree& r) { leaves = expectSameLeaves(t, r); });
  });
  EXPECT_GT(leaves, 100000u);
  EXPECT_EQ(countLeaves(map, 0), countLeaves(reference, 0)) << "pruned alike";

  // Moving more than partial_rebuild_max_fraction of the keyframes rebuilds the whole tree.
  std::map<int64_t, std::pair<int, SE3>> all_moved;
  for (size_t i = 0; i < all.size(); ++i)
    all_moved[all[i].first.keyframe_id] = {0, Eigen::Translation3d(0.2, 0.0, 0.0) * expected[i]};
  EXPECT_TRUE(map.updatePoses(all_moved));
  ASSERT_TRUE(map.waitIdle(60.0));
  EXPECT_EQ(map.stats().rebuilds, 2u);
  EXPECT_EQ(map.stats().partial_rebuilds, 1u);
  EXPECT_EQ(map.stats().last_rebuild_keyframes, all.size());
}

// A partial rebuild keeps the moved keyframes' ray casts between its passes only up to
// partial_rebuild_held_mb (unbounded: 378 MB of the heap's peak at 5,000 keyframes); beyond, it casts them
// again: the same tree, three more casts for three moved keyframes.
TEST(OccupancyMap, APartialRebuildOverItsHeldBudgetCastsAgainAndBuildsTheSameTree) {
  const auto& kf = makeSynthKeyframes("sweep", 12);
  OccupancyMapConfig unbounded = testConfig(), bounded = testConfig();
  bounded.partial_rebuild_held_mb = 0;
  OccupancyMap a(unbounded), b(bounded);
  insertAll(&a, kf, 0);
  insertAll(&b, kf, 0);
  std::map<int64_t, std::pair<int, SE3>> moved;
  for (size_t i = 9; i < kf.clouds.size(); ++i)
    moved[int64_t(i)] = {0, Eigen::Translation3d(0.0, 0.2, 0.0) * kf.T_world_cam[i]};
  EXPECT_TRUE(a.updatePoses(moved));
  EXPECT_TRUE(b.updatePoses(moved));
  ASSERT_TRUE(a.waitIdle(60.0));
  ASSERT_TRUE(b.waitIdle(60.0));
  EXPECT_EQ(a.stats().partial_rebuilds, 1u);
  EXPECT_EQ(b.stats().partial_rebuilds, 1u);
  EXPECT_EQ(b.stats().last_rebuild_keyframes, a.stats().last_rebuild_keyframes + moved.size());
  a.read(0, [&](const octomap::OcTree& x) {
    b.read(0, [&](const octomap::OcTree& y) { EXPECT_GT(expectSameLeaves(x, y), 10000u); });
  });
}

// Kept clouds beyond clouds_in_memory go to the spill file and come back for rebuilds and exports
// exactly as they were: the same trees after a partial and a whole rebuild, the same exported clouds.
TEST(OccupancyMap, ReadersNeverSeeAHalfBuiltTree) {
  const OccupancyMapConfig config = testConfig();
  const auto& kf = makeSynthKeyframes("sweep", 12);
  const SE3 shift(Eigen::Translation3d(0.25, 0.1, 0.0));
  // The two complete states: all keyframes at their poses, and all shifted.
  LeafCounts a, b;
  {
    OccupancyMap ref(config);
    insertAll(&ref, kf, 0, 0, ~size_t{0}, shift);
    b = countLeaves(ref, 0);
  }
  OccupancyMap map(config);
  insertAll(&map, kf, 0);
  a = countLeaves(map, 0);
  ASSERT_FALSE(a == b);

  std::atomic<bool> done{false};
  std::atomic<int> reads{0}, bad{0};
  std::thread reader([&] {
    while (!done) {
      ASSERT_TRUE(map.read(0, [&](const octomap::OcTree& t) {
        const LeafCounts c = countLeaves(t);
        if (!(c == a) && !(c == b)) ++bad;
      }));
      ++reads;
    }
  });
  for (int round = 0; round < 2; ++round) {  // shifted, then back
    std::map<int64_t, std::pair<int, SE3>> poses;
    for (size_t i = 0; i < kf.clouds.size(); ++i)
      poses[int64_t(i)] = {0, (round == 0 ? shift : SE3::Identity()) * kf.T_world_cam[i]};
    EXPECT_TRUE(map.updatePoses(poses));
    ASSERT_TRUE(map.waitIdle(30.0));
  }
  done = true;
  reader.join();
  EXPECT_EQ(bad.load(), 0);
  EXPECT_GT(reads.load(), 4);
  EXPECT_EQ(countLeaves(map, 0), a);  // back at the original poses: the same tree as built incrementally
  EXPECT_EQ(map.stats().rebuilds, 2u);
}

TEST(OccupancyMap, KeyframesInsertedDuringARebuildAreKept) {
  const OccupancyMapConfig config = testConfig();
  const auto& kf = makeSynthKeyframes("loop", 12);
  const SE3 shift(Eigen::Translation3d(0.0, 0.2, 0.0));
  OccupancyMap reference(config);
  insertAll(&reference, kf, 0, 0, ~size_t{0}, shift);
  OccupancyMap map(config);
  insertAll(&map, kf, 0, 0, 6);
  std::map<int64_t, std::pair<int, SE3>> poses;
  for (size_t i = 0; i < 6; ++i) poses[int64_t(i)] = {0, shift * kf.T_world_cam[i]};
  EXPECT_TRUE(map.updatePoses(poses));
  insertAll(&map, kf, 0, 6, ~size_t{0}, shift);  // while the rebuild runs
  ASSERT_TRUE(map.waitIdle(30.0));
  EXPECT_EQ(countLeaves(map, 0), countLeaves(reference, 0));
  EXPECT_EQ(map.stats().keyframes, 12u);
  EXPECT_GE(map.stats().rebuilds, 1u);
}

TEST(OccupancyMap, MergingTwoMapIdsRebuildsOneTree) {
  const OccupancyMapConfig config = testConfig();
  const auto& kf = makeSynthKeyframes("loop", 12);
  // Robot 1 mapped the second half in its own frame (rotated and offset from the world).
  const SE3 T_m1_world = Eigen::Translation3d(1.0, -0.5, 0.2) * Eigen::AngleAxisd(0.7, Vec3::UnitZ());
  OccupancyMap map(config);
  insertAll(&map, kf, 0, 0, 6);
  insertAll(&map, kf, 1, 6, 12, T_m1_world);
  EXPECT_EQ(map.mapIds(), (std::vector<int>{0, 1}));
  // Map 1 holds robot 1's keyframes in its own frame: its occupied cells, taken back to the world, lie on
  // the room's surfaces.
  size_t occupied = 0, near_surface = 0;
  const SE3 T_world_m1 = T_m1_world.inverse();
  map.read(1, [&](const octomap::OcTree& t) {
    for (auto it = t.begin_leafs(), end = t.end_leafs(); it != end; ++it) {
      if (!t.isNodeOccupied(*it)) continue;
      ++occupied;
      const octomap::point3d c = it.getCoordinate();
      near_surface +=
          kf.scene->distanceToSurface(T_world_m1 * Vec3(c.x(), c.y(), c.z())) <= 2 * config.resolution_m;
    }
  });
  ASSERT_GT(occupied, 1000u);
  EXPECT_GE(double(near_surface) / occupied, 0.95);

  std::map<int64_t, std::pair<int, SE3>> merge;
  for (size_t i = 6; i < 12; ++i) merge[int64_t(i)] = {0, kf.T_world_cam[i]};
  EXPECT_TRUE(map.updatePoses(merge));
  EXPECT_EQ(map.mapIds(), (std::vector<int>{0})) << "the merged-away map's tree is dropped at once";
  ASSERT_TRUE(map.waitIdle(30.0));
  EXPECT_EQ(map.mapIds(), (std::vector<int>{0}));
  EXPECT_EQ(map.revision(1), 0u);
  OccupancyMap reference(config);
  insertAll(&reference, kf, 0);
  EXPECT_EQ(countLeaves(map, 0), countLeaves(reference, 0));
}

}  // namespace
}  // namespace rgbdmap
