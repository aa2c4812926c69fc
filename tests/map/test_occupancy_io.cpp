// Occupancy map outputs: 2-D slices of a known scene, octree bytes (round trip, garbage, truncation),
// .bt/.ot files re-read by OctoMap itself (and left whole when a write fails), partial map streams.
#include <cstdio>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

#include "common/file_size_limit.hpp"
#include "occupancy_fixture.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/proto/map_payload.hpp"

namespace rgbdmap {
namespace {

using testing::countLeaves;
using testing::makeSynthKeyframes;

/// The sweep's map (facing the +x wall 2.3-2.6 m away), built once for the tests below.
struct SweepMap {
  testing::SynthKeyframes kf;
  std::unique_ptr<OccupancyMap> map;
};
const SweepMap& sweepMap() {
  static const SweepMap m = [] {
    SweepMap s;
    s.kf = makeSynthKeyframes("sweep", 6);
    s.map = std::make_unique<OccupancyMap>(OccupancyMapConfig{});
    for (size_t i = 0; i < s.kf.clouds.size(); ++i)
      EXPECT_TRUE(s.map->insert(s.kf.clouds[i], 0, s.kf.T_world_cam[i]).ok());
    return s;
  }();
  return m;
}

std::unique_ptr<octomap::OcTree> copyTree(const OccupancyMap& map, int map_id) {
  std::unique_ptr<octomap::OcTree> out;
  map.read(map_id, [&](const octomap::OcTree& t) { out = std::make_unique<octomap::OcTree>(t); });
  return out;
}

TEST(OccupancySlice, WallAheadIsOccupiedSpaceBeforeFreeBehindUnknown) {
  const SweepMap& m = sweepMap();
  const SE3& T = m.kf.T_world_cam[3];
  SliceConfig config;
  config.up_in_map = Vec3::UnitZ();  // the synthetic world is z-up
  msg::OccupancySlice slice;
  ASSERT_TRUE(m.map->read(0, [&](const octomap::OcTree& tree) {
    auto s = extractSlice(tree, T, config);
    ASSERT_TRUE(s.ok()) << s.error();
    slice = *s;
  }));
  ASSERT_EQ(slice.width, 160);
  ASSERT_EQ(slice.cells.size(), 160u * 160u);
  const double res = config.resolution_m;
  const Vec3 x = slice.T_map_grid.linear().col(0), up = slice.T_map_grid.linear().col(2);
  EXPECT_NEAR(up.z(), 1.0, 1e-9);
  EXPECT_GT(x.dot(T.linear().col(2)), 0.95);  // grid x = camera forward on the floor plane
  size_t free_ok = 0, free_n = 0, unknown_ok = 0, unknown_n = 0, rows_with_wall = 0, rows = 0;
  for (int row = 70; row < 90; ++row) {  // +-0.5 m around the robot
    // True first surface along this row at a few heights of the band.
    const Vec3 c0 = slice.T_map_grid * Vec3(0.5 * res, (row + 0.5) * res, 0.0);
    double near = 1e9, far = 0;
    for (double h : {-0.25, -0.1, 0.0, 0.1, 0.25}) {
      const Vec3 from = c0 + 4.0 * x + h * up;  // the robot is at 4 m along the row
      const auto hit = m.kf.scene->castRay(from, x);
      ASSERT_TRUE(hit);
      near = std::min(near, hit->t);
      far = std::max(far, hit->t);
    }
    ++rows;
    bool wall = false;
    for (int col = 80; col < 160; ++col) {
      const double ahead = (col + 0.5) * res - 4.0;
      const int8_t v = slice.cells[size_t(row) * 160 + col];
      if (ahead > 1.0 && ahead < near - 0.15) {
        ++free_n;
        free_ok += v == msg::OccupancySlice::kFree;
      }
      if (ahead > near - res - 1e-9 && ahead < far + 2 * res && v == msg::OccupancySlice::kOccupied)
        wall = true;
      if (ahead > far + 0.3) {
        ++unknown_n;
        unknown_ok += v == msg::OccupancySlice::kUnknown;
      }
    }
    rows_with_wall += wall;
    for (int col = 0; col < 60; ++col) {  // behind the robot: never seen
      ++unknown_n;
      unknown_ok += slice.cells[size_t(row) * 160 + col] == msg::OccupancySlice::kUnknown;
    }
  }
  EXPECT_GE(double(free_ok) / free_n, 0.9) << free_ok << "/" << free_n;
  EXPECT_GE(double(unknown_ok) / unknown_n, 0.95) << unknown_ok << "/" << unknown_n;
  EXPECT_EQ(rows_with_wall, rows);
}

TEST(OccupancySlice, TiltedUpAgreesWithAxisAlignedUp) {
  // An up vector off the key axes takes the general per-sample path; a tiny tilt must give the same grid.
  const SweepMap& m = sweepMap();
  SliceConfig aligned;
  aligned.up_in_map = Vec3::UnitZ();
  SliceConfig tilted = aligned;
  tilted.up_in_map = Vec3(1e-4, -1e-4, 1.0);
  size_t same = 0, known = 0, total = 0;
  m.map->read(0, [&](const octomap::OcTree& tree) {
    const auto a = extractSlice(tree, m.kf.T_world_cam[2], aligned);
    const auto b = extractSlice(tree, m.kf.T_world_cam[2], tilted);
    ASSERT_TRUE(a.ok() && b.ok());
    total = a->cells.size();
    for (size_t i = 0; i < total; ++i) {
      same += a->cells[i] == b->cells[i];
      known += a->cells[i] != msg::OccupancySlice::kUnknown;
    }
  });
  EXPECT_GT(known, 2000u);
  EXPECT_GE(double(same) / total, 0.98) << same << "/" << total;
}

TEST(OccupancySlice, RejectsBadConfigAndPose) {
  octomap::OcTree tree(0.05);
  SliceConfig config;
  EXPECT_TRUE(extractSlice(tree, SE3::Identity(), config).ok());  // empty tree: all unknown
  config.resolution_m = 0.0;
  config.z_min_m = 1.0;
  const auto bad = extractSlice(tree, SE3::Identity(), config);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("resolution_m"), std::string::npos);
  EXPECT_NE(bad.error().find("z_min_m"), std::string::npos);
  SE3 nan_pose = SE3::Identity();
  nan_pose(1, 1) = std::nan("");
  EXPECT_FALSE(extractSlice(tree, nan_pose, SliceConfig{}).ok());
  const auto all_unknown = extractSlice(tree, SE3::Identity(), SliceConfig{});
  for (int8_t v : all_unknown->cells) ASSERT_EQ(v, msg::OccupancySlice::kUnknown);
}

TEST(OctreeBytes, RoundTripKeepsEveryLeaf) {
  const auto tree = copyTree(*sweepMap().map, 0);
  ASSERT_TRUE(tree);
  const auto bytes = serializeTree(*tree);
  ASSERT_TRUE(bytes.ok()) << bytes.error();
  const auto back = deserializeTree(*bytes);
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(countLeaves(**back), countLeaves(*tree));
  EXPECT_DOUBLE_EQ((*back)->getResolution(), tree->getResolution());
  EXPECT_EQ(*serializeTree(**back), *bytes);
  const auto empty = deserializeTree(*serializeTree(octomap::OcTree(0.1)));
  ASSERT_TRUE(empty.ok()) << empty.error();
  EXPECT_EQ((*empty)->size(), 0u);
}

TEST(OctreeBytes, GarbageAndTruncatedBytesFailCleanly) {
  const auto tree = copyTree(*sweepMap().map, 0);
  const std::vector<uint8_t> good = *serializeTree(*tree);
  EXPECT_FALSE(deserializeTree({}).ok());
  std::mt19937 rng(9);
  for (int i = 0; i < 200; ++i) {  // random bytes, with and without a valid header
    std::vector<uint8_t> junk(rng() % 4000);
    for (auto& b : junk) b = static_cast<uint8_t>(rng());
    EXPECT_FALSE(deserializeTree(junk).ok());
    std::string headed(good.begin(), good.begin() + 80);
    headed.append(junk.begin(), junk.end());
    (void)deserializeTree(
        std::vector<uint8_t>(headed.begin(), headed.end()));  // may parse by chance; must not crash
  }
  // Every inner node marks all children inner: would recurse forever without the depth check.
  std::string deep = "# Octomap OcTree binary file\nid OcTree\nsize 100\nres 0.05\ndata\n";
  std::vector<uint8_t> deep_bytes(deep.begin(), deep.end());
  deep_bytes.resize(deep_bytes.size() + 100000, 0xFF);
  const auto r = deserializeTree(deep_bytes);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("corrupt"), std::string::npos) << r.error();
  size_t failures = 0, cuts = 0;
  for (size_t n = 0; n < good.size(); n += 1 + good.size() / 300, ++cuts)
    failures += !deserializeTree(std::vector<uint8_t>(good.begin(), good.begin() + long(n))).ok();
  EXPECT_EQ(failures, cuts);
  for (int i = 0; i < 200; ++i) {  // bit flips in the data: fail or parse, never crash
    std::vector<uint8_t> flipped = good;
    flipped[80 + rng() % (flipped.size() - 80)] ^= static_cast<uint8_t>(1u << (rng() % 8));
    (void)deserializeTree(flipped);
  }
  std::string wrong_type = "# Octomap OcTree binary file\nid ColorOcTree\nsize 0\nres 0.05\ndata\n";
  EXPECT_FALSE(deserializeTree(std::vector<uint8_t>(wrong_type.begin(), wrong_type.end())).ok());
  std::string bad_res = "# Octomap OcTree binary file\nid OcTree\nsize 0\nres nan\ndata\n";
  EXPECT_FALSE(deserializeTree(std::vector<uint8_t>(bad_res.begin(), bad_res.end())).ok());
}

TEST(OctreeFiles, BtAndOtAreReadByOctoMapItself) {
  const auto tree = copyTree(*sweepMap().map, 0);
  const std::string dir = ::testing::TempDir();
  const std::string bt = dir + "/octree_test.bt", ot = dir + "/octree_test.ot";
  ASSERT_TRUE(writeMapFiles(*tree, bt, ot).ok());
  octomap::OcTree from_bt(0.1);
  ASSERT_TRUE(from_bt.readBinary(bt));
  EXPECT_EQ(countLeaves(from_bt), countLeaves(*tree));
  std::unique_ptr<octomap::AbstractOcTree> abstract(octomap::AbstractOcTree::read(ot));
  auto* from_ot = dynamic_cast<octomap::OcTree*>(abstract.get());
  ASSERT_NE(from_ot, nullptr);
  EXPECT_EQ(countLeaves(*from_ot), countLeaves(*tree));
  for (const std::string& path : {bt, ot}) {
    const auto ours = readMapFile(path);
    ASSERT_TRUE(ours.ok()) << ours.error();
    EXPECT_EQ(countLeaves(**ours), countLeaves(*tree)) << path;
  }
  EXPECT_FALSE(readMapFile(dir + "/does_not_exist.bt").ok());
  EXPECT_FALSE(writeMapFiles(*tree, dir + "/no/such/dir/x.bt", "").ok());
  std::remove(bt.c_str());
  std::remove(ot.c_str());
}

TEST(OctreeFiles, AFailedWriteLeavesTheOldFilesWhole) {
  // A full disk used to leave a truncated map.bt in place of the good one.
  const auto tree = copyTree(*sweepMap().map, 0);
  octomap::OcTree small(0.1);
  small.updateNode(octomap::point3d(0.0f, 0.0f, 0.0f), true);
  const std::string dir = ::testing::TempDir();
  const std::string bt = dir + "/octree_full_disk.bt", ot = dir + "/octree_full_disk.ot";
  ASSERT_TRUE(writeMapFiles(small, bt, ot).ok());
  const auto bt_size = std::filesystem::file_size(bt), ot_size = std::filesystem::file_size(ot);
  ASSERT_GT(serializeTree(*tree)->size(), 3 * bt_size);
  {
    testing::FileSizeLimit full(bt_size + 16);  // room for the small map, not the sweep's
    ASSERT_TRUE(full.ok());
    EXPECT_FALSE(writeMapFiles(*tree, bt, ""));
    EXPECT_FALSE(writeMapFiles(*tree, "", ot));
  }
  EXPECT_EQ(std::filesystem::file_size(bt), bt_size);
  EXPECT_EQ(std::filesystem::file_size(ot), ot_size);
  for (const std::string& path : {bt, ot}) {
    const auto old = readMapFile(path);
    ASSERT_TRUE(old.ok()) << path << ": " << old.error();
    EXPECT_EQ(countLeaves(**old), countLeaves(small)) << path;
  }
  std::remove(bt.c_str());
  std::remove(ot.c_str());
}

TEST(MapStream, PartialUpdatesReproduceTheSendersTree) {
  const OccupancyMapConfig config;
  const auto& kf = makeSynthKeyframes("loop", 12);
  OccupancyMap map(config);
  for (size_t i = 0; i < 8; ++i) ASSERT_TRUE(map.insert(kf.clouds[i], 0, kf.T_world_cam[i]).ok());
  std::unique_ptr<octomap::OcTree> receiver;
  auto first = map.streamSince(0, 0);
  ASSERT_TRUE(first.ok()) << first.error();
  EXPECT_TRUE(first->full);
  msg::MapUpdate update;
  ASSERT_TRUE(fillMapUpdate(*first, config.resolution_m, &update).ok());
  ASSERT_TRUE(applyMapUpdate(update, &receiver).ok());
  uint64_t have = first->revision;
  std::unique_ptr<octomap::OcTree> slow;  // a consumer that skips the 4 partials below and takes one after
  ASSERT_TRUE(applyMapUpdate(update, &slow).ok());
  const uint64_t slow_have = first->revision;
  size_t changed_each = 0;
  for (size_t i = 8; i < 12; ++i) {
    ASSERT_TRUE(map.insert(kf.clouds[i], 0, kf.T_world_cam[i]).ok());
    auto chunk = map.streamSince(0, have);
    ASSERT_TRUE(chunk.ok());
    EXPECT_FALSE(chunk->full) << "keyframe " << i;
    EXPECT_GT(chunk->changed_leaves, 0u);
    ASSERT_TRUE(fillMapUpdate(*chunk, config.resolution_m, &update).ok());
    EXPECT_FALSE(update.full);
    ASSERT_TRUE(applyMapUpdate(update, &receiver).ok());
    have = chunk->revision;
    changed_each += chunk->changed_leaves;
  }
  // The slow consumer's one partial covers 4 revisions: a leaf changed in several of them comes once.
  auto catch_up = map.streamSince(0, slow_have);
  ASSERT_TRUE(catch_up.ok());
  EXPECT_FALSE(catch_up->full);
  EXPECT_GT(catch_up->changed_leaves, 0u);
  EXPECT_LT(catch_up->changed_leaves, changed_each) << "no leaf changed twice: the test shows nothing";
  ASSERT_TRUE(fillMapUpdate(*catch_up, config.resolution_m, &update).ok());
  ASSERT_TRUE(applyMapUpdate(update, &slow).ok());
  // Every leaf of the sender has the same state at both receivers.
  for (const octomap::OcTree* r : {receiver.get(), slow.get()}) {
    size_t leaves = 0, same = 0;
    map.read(0, [&](const octomap::OcTree& t) {
      for (auto it = t.begin_leafs(), end = t.end_leafs(); it != end; ++it) {
        ++leaves;
        const octomap::OcTreeNode* n = r->search(it.getCoordinate());
        same += n && r->isNodeOccupied(n) == t.isNodeOccupied(*it);
      }
    });
    EXPECT_EQ(same, leaves);
  }
  EXPECT_FALSE(map.streamSince(5, 0).ok());
  std::unique_ptr<octomap::OcTree> none;
  MapStreamChunk partial = *map.streamSince(0, have);
  partial.full = false;
  EXPECT_FALSE(applyMapChunk(**deserializeTree(partial.bytes), false, &none).ok());
}

}  // namespace
}  // namespace rgbdmap
