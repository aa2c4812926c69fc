// The global 2-D map of a tree (extractMapGrid): its extent, its axes (no yaw) and every cell against an
// independent cut of the same octree (OcTree::search at the cell's sample heights).
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "rgbdmap/map/occupancy_slice.hpp"

namespace rgbdmap {
namespace {

/// A room-like tree at 0.05 m: a free floor slab, walls occupied, an obstacle above the band, a random
/// scatter of occupied and free voxels; z-up, the camera at z = 0.4.
octomap::OcTree makeTree() {
  octomap::OcTree tree(0.05);
  const auto set = [&](double x, double y, double z, bool occupied) {
    tree.updateNode(octomap::point3d(float(x), float(y), float(z)), occupied);
    tree.updateNode(octomap::point3d(float(x), float(y), float(z)), occupied);
  };
  for (double x = -1.0; x < 2.0; x += 0.05)
    for (double y = -0.5; y < 1.5; y += 0.05) {
      for (double z = 0.125; z < 0.7; z += 0.05) set(x, y, z, false);  // free space of the room
      if (x < -0.95 || x > 1.95 || y > 1.45) set(x, y, 0.375, true);   // walls in the band
    }
  for (double x = 0.5; x < 0.8; x += 0.05) set(x, 0.2, 1.125, true);  // a shelf above the band: not in it
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(-1.0, 2.0), uy(-0.5, 1.5), uz(0.1, 0.8);
  for (int i = 0; i < 300; ++i) set(ux(rng), uy(rng), uz(rng), i % 3 == 0);
  return tree;
}

/// The cut of one cell, written independently of extractMapGrid: occupied if any sample height is, free if
/// any is, else unknown.
int8_t expectedCell(const octomap::OcTree& tree, const Vec3& centre, double z_min, double z_max) {
  const double res = tree.getResolution();
  const int levels = std::max(1, int(std::ceil((z_max - z_min) / res - 1e-9)));
  const double dz = (z_max - z_min) / levels;
  int8_t best = -1;
  for (int l = 0; l < levels; ++l) {
    const Vec3 p = centre + Vec3(0, 0, z_min + (l + 0.5) * dz);
    const octomap::OcTreeNode* n = tree.search(p.x(), p.y(), p.z());
    if (!n) continue;
    if (tree.isNodeOccupied(n)) return 100;
    best = 0;
  }
  return best;
}

TEST(MapGrid, CellsMatchTheOctreeCut) {
  const octomap::OcTree tree = makeTree();
  SliceConfig config;  // 0.05 m cells, band -0.3..0.3 m around the camera height, z up
  const auto grid = extractMapGrid(tree, 0.4, config);
  ASSERT_TRUE(grid) << grid.error();
  EXPECT_TRUE(grid->T_map_grid.linear().isApprox(Mat3::Identity(), 1e-12)) << "axis-aligned: no yaw";
  EXPECT_NEAR(grid->T_map_grid.translation().z(), 0.4, 1e-12);
  EXPECT_TRUE(grid->robot_id.empty());
  double x0, y0, z0, x1, y1, z1;
  tree.getMetricMin(x0, y0, z0);
  tree.getMetricMax(x1, y1, z1);
  EXPECT_NEAR(grid->T_map_grid.translation().x(), x0, 1e-9);
  EXPECT_NEAR(grid->T_map_grid.translation().y(), y0, 1e-9);
  EXPECT_GE(grid->width * 0.05, x1 - x0 - 1e-6);
  EXPECT_GE(grid->height * 0.05, y1 - y0 - 1e-6);
  ASSERT_EQ(grid->cells.size(), size_t(grid->width) * grid->height);
  size_t counts[3] = {0, 0, 0}, mismatches = 0;
  for (int row = 0; row < grid->height; ++row)
    for (int col = 0; col < grid->width; ++col) {
      const Vec3 c = grid->T_map_grid * Vec3((col + 0.5) * 0.05, (row + 0.5) * 0.05, 0.0) - Vec3(0, 0, 0.4);
      const int8_t want = expectedCell(tree, c, 0.4 + config.z_min_m, 0.4 + config.z_max_m);
      const int8_t got = grid->cells[size_t(row) * grid->width + col];
      mismatches += got != want;
      ++counts[want < 0 ? 0 : want == 0 ? 1 : 2];
    }
  EXPECT_EQ(mismatches, 0u);
  EXPECT_GT(counts[1], 1000u) << "free cells";
  EXPECT_GT(counts[2], 100u) << "occupied cells";
  EXPECT_GT(counts[0], 0u) << "unknown cells";
}

TEST(MapGrid, ShelfAboveTheBandIsNotAnObstacle) {
  const octomap::OcTree tree = makeTree();
  const auto grid = extractMapGrid(tree, 0.4, SliceConfig{});
  ASSERT_TRUE(grid) << grid.error();
  const Vec3 local = grid->T_map_grid.inverse() * Vec3(0.625, 0.225, 0.4);
  const int col = int(local.x() / 0.05), row = int(local.y() / 0.05);
  EXPECT_NE(grid->cells[size_t(row) * grid->width + col], 100);
  const auto high = extractMapGrid(tree, 1.1, SliceConfig{});  // cut at the shelf's height: occupied
  ASSERT_TRUE(high);
  EXPECT_EQ(high->cells[size_t(row) * high->width + col], 100);
}

TEST(MapGrid, LargeMapsGetCoarserCellsAndBadInputFails) {
  octomap::OcTree tree(0.05);
  tree.updateNode(octomap::point3d(0, 0, 0), true);
  tree.updateNode(octomap::point3d(300, 10, 0), true);  // 300 m: 6000 cells at 0.05 m
  const auto grid = extractMapGrid(tree, 0.0, SliceConfig{});
  ASSERT_TRUE(grid) << grid.error();
  EXPECT_LE(grid->width, msg::kMaxGridSide);
  EXPECT_NEAR(grid->resolution_m, 0.1, 1e-6);
  EXPECT_FALSE(extractMapGrid(octomap::OcTree(0.05), 0.0, SliceConfig{})) << "empty tree";
  EXPECT_FALSE(extractMapGrid(tree, std::nan(""), SliceConfig{}));
  SliceConfig bad;
  bad.z_min_m = 1.0;
  bad.z_max_m = 0.0;
  EXPECT_FALSE(extractMapGrid(tree, 0.0, bad));
}

}  // namespace
}  // namespace rgbdmap
