// Map bundles: export -> import round trip, info, and refusal of damaged, truncated, foreign and hostile
// files, which change nothing.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "common/temp_dir.hpp"
#include "rgbdmap/store/map_bundle.hpp"
#include "store/map_store_test_util.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;
using testing::expectSameKeyframe;
using testing::expectSameLoop;
using testing::makeKeyframe;
using testing::makeLoop;
using testing::openStore;
using testing::TempDir;

std::string readBundleFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

void writeBundleFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

/// A map directory: four keyframes of two robots (small random images), two loops (one with matches), a
/// robots.txt and an "octree".
struct SampleMap {
  std::vector<StoredKeyframe> keyframes;
  std::vector<StoredLoop> loops;
  explicit SampleMap(const std::string& dir) {
    for (int64_t id = 0; id < 4; ++id)
      keyframes.push_back(
          makeKeyframe(id, id % 2, testing::randomImages(64, 48, static_cast<uint32_t>(id)), 40));
    loops = {makeLoop(1, 3), makeLoop(0, 2)};
    auto store = openStore(dir);
    for (const auto& k : keyframes) EXPECT_TRUE(store->appendKeyframe(k));
    for (const auto& l : loops) EXPECT_TRUE(store->appendLoop(l));
    writeBundleFile(dir + "/robots.txt",
                    "# rgbdmap robots v2\nrobot_0 0 525 525 31.5 23.5 64 48 0 0 0 0 0 5000\n");
    writeBundleFile(dir + "/map.bt",
                    std::string("# Octomap OcTree binary file\n") + std::string(300, '\x5a'));
    writeBundleFile(dir + "/map.png", "not carried");
  }
};

TEST(MapBundle, ExportThenImportGivesTheSameMap) {
  TempDir tmp;
  const SampleMap sample(tmp.path("map"));
  auto exported = store::exportMapBundle(tmp.path("map"), tmp.path("map.rmb"));
  ASSERT_TRUE(exported) << exported.error();
  EXPECT_EQ(exported->keyframes, 4);
  EXPECT_EQ(exported->loops, 2);
  EXPECT_EQ(exported->keyframes_per_robot.at("robot_0"), 2);
  EXPECT_EQ(exported->sessions, (std::vector<int64_t>{1000, 1001}));
  EXPECT_EQ(exported->files.size(), 2u) << "robots.txt and map.bt; map.png is an output, not carried";
  EXPECT_EQ(exported->bundle_bytes, static_cast<int64_t>(fs::file_size(tmp.path("map.rmb"))));

  auto imported = store::importMapBundle(tmp.path("map.rmb"), tmp.path("copy"));
  ASSERT_TRUE(imported) << imported.error();
  EXPECT_EQ(imported->keyframes, 4);
  for (const char* name : {"robots.txt", "map.bt"})
    EXPECT_EQ(readBundleFile(tmp.path("copy/") + name), readBundleFile(tmp.path("map/") + name)) << name;
  EXPECT_FALSE(fs::exists(tmp.path("copy/map.png")));
  EXPECT_EQ(readBundleFile(tmp.path("copy/keyframes.log")), readBundleFile(tmp.path("map/keyframes.log")));
  EXPECT_EQ(readBundleFile(tmp.path("copy/loops.log")), readBundleFile(tmp.path("map/loops.log")));
  auto store = openStore(tmp.path("copy"));
  ASSERT_EQ(store->keyframes().size(), 4u);
  for (const auto& k : sample.keyframes) {
    auto full = store->readKeyframe(k.node_id);
    ASSERT_TRUE(full) << full.error();
    expectSameKeyframe(*full, k, true);
  }
  ASSERT_EQ(store->loops().size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    StoredLoop loop = store->loops()[i];
    loop.inlier_pairs = store->readLoopPairs(i).value();
    expectSameLoop(loop, sample.loops[i]);
  }
}

TEST(MapBundle, InfoVerifiesAndDescribes) {
  TempDir tmp;
  const SampleMap sample(tmp.path("map"));
  ASSERT_TRUE(store::exportMapBundle(tmp.path("map"), tmp.path("map.rmb")));
  auto info = store::readMapBundleInfo(tmp.path("map.rmb"));
  ASSERT_TRUE(info) << info.error();
  EXPECT_EQ(info->format_version, store::kMapBundleFormatVersion);
  EXPECT_EQ(info->message_schema_version, msg::kSchemaVersion);
  EXPECT_EQ(info->source, fs::path(tmp.path("map")).lexically_normal().string());
  EXPECT_EQ(info->created_utc.size(), 20u) << info->created_utc;
  EXPECT_EQ(info->files.at("map.bt"), static_cast<int64_t>(fs::file_size(tmp.path("map/map.bt"))));
}

TEST(MapBundle, ADamagedBundleIsRefusedAtEveryRegionAndChangesNothing) {
  TempDir tmp;
  const SampleMap sample(tmp.path("map"));
  ASSERT_TRUE(store::exportMapBundle(tmp.path("map"), tmp.path("map.rmb")));
  const std::string good = readBundleFile(tmp.path("map.rmb"));
  testing::QuietLog quiet;
  // A flipped bit anywhere (sampled: every 97th byte, and the first and last ones), then truncations.
  std::vector<size_t> offsets = {0, 8, 12, good.size() - 33, good.size() - 1};
  for (size_t at = 1; at < good.size(); at += 97) offsets.push_back(at);
  for (size_t at : offsets) {
    std::string bad = good;
    bad[at] = static_cast<char>(bad[at] ^ 0x10);
    writeBundleFile(tmp.path("bad.rmb"), bad);
    auto r = store::importMapBundle(tmp.path("bad.rmb"), tmp.path("target"));
    ASSERT_FALSE(r) << "a flipped bit at byte " << at << " was accepted";
    ASSERT_FALSE(fs::exists(tmp.path("target"))) << at;
  }
  for (size_t size : {size_t{0}, size_t{11}, size_t{44}, good.size() / 2, good.size() - 1}) {
    writeBundleFile(tmp.path("bad.rmb"), good.substr(0, size));
    auto r = store::importMapBundle(tmp.path("bad.rmb"), tmp.path("target"));
    ASSERT_FALSE(r) << "truncated to " << size;
    EXPECT_FALSE(store::readMapBundleInfo(tmp.path("bad.rmb")));
  }
  for (const fs::directory_entry& e : fs::directory_iterator(tmp.dir()))
    EXPECT_TRUE(e.path().filename() == "map" || e.path().filename() == "map.rmb" ||
                e.path().filename() == "bad.rmb")
        << "left behind: " << e.path();
}

TEST(MapBundle, ForeignFilesAndOccupiedTargetsAreRefusedWithAReason) {
  TempDir tmp;
  const SampleMap sample(tmp.path("map"));
  ASSERT_TRUE(store::exportMapBundle(tmp.path("map"), tmp.path("map.rmb")));
  writeBundleFile(tmp.path("foreign"), std::string(4096, 'x'));
  auto foreign = store::importMapBundle(tmp.path("foreign"), tmp.path("target"));
  ASSERT_FALSE(foreign);
  EXPECT_NE(foreign.error().find("not an rgbdmap map bundle"), std::string::npos) << foreign.error();
  // Into the map it came from (not empty): refused, the map untouched.
  const std::string before = readBundleFile(tmp.path("map/keyframes.log"));
  auto occupied = store::importMapBundle(tmp.path("map.rmb"), tmp.path("map"));
  ASSERT_FALSE(occupied);
  EXPECT_NE(occupied.error().find("not an empty folder"), std::string::npos) << occupied.error();
  EXPECT_EQ(readBundleFile(tmp.path("map/keyframes.log")), before);
  // An empty folder is fine.
  fs::create_directories(tmp.path("empty"));
  EXPECT_TRUE(store::importMapBundle(tmp.path("map.rmb"), tmp.path("empty")));
  // Exporting what is not a map directory, or a map a server holds open, says so.
  auto not_a_map = store::exportMapBundle(tmp.path("nothing"), tmp.path("x.rmb"));
  ASSERT_FALSE(not_a_map);
  EXPECT_NE(not_a_map.error().find("not a map directory"), std::string::npos) << not_a_map.error();
  EXPECT_FALSE(fs::exists(tmp.path("nothing")));
  auto held = openStore(tmp.path("map"));
  auto locked = store::exportMapBundle(tmp.path("map"), tmp.path("x.rmb"));
  EXPECT_FALSE(locked);
  EXPECT_FALSE(fs::exists(tmp.path("x.rmb")));
}

}  // namespace
}  // namespace rgbdmap
