// Map store: round trips, reopening, the directory lock, refused input and format versions, concurrent
// reads during appends. Crash recovery (truncation, corruption) is in test_map_store_recovery.cpp.
#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "common/temp_dir.hpp"
#include "store/map_store_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::expectSameKeyframe;
using testing::expectSameLoop;
using testing::makeKeyframe;
using testing::makeLoop;

using testing::openStore;

/// Six keyframes of two robots with rendered 640x480 images, and three loops.
struct Sample {
  std::vector<StoredKeyframe> keyframes;
  std::vector<StoredLoop> loops;
  Sample() {
    const auto& images = testing::renderedImages();
    for (int64_t id = 0; id < 6; ++id) keyframes.push_back(makeKeyframe(id, id % 2, images[id % 2]));
    loops = {makeLoop(0, 4), makeLoop(1, 5), makeLoop(5, 2)};
  }
  void appendTo(MapStore* store) const {
    for (const auto& k : keyframes) ASSERT_TRUE(store->appendKeyframe(k).ok());
    for (const auto& l : loops) ASSERT_TRUE(store->appendLoop(l).ok());
  }
};

void expectContent(const MapStore& store, const Sample& sample) {
  ASSERT_EQ(store.keyframes().size(), sample.keyframes.size());
  for (size_t i = 0; i < sample.keyframes.size(); ++i) {
    const StoredKeyframe& kept = store.keyframes()[i];
    EXPECT_TRUE(kept.keyframe.images.depth.empty() && kept.keyframe.images.color.empty());
    expectSameKeyframe(kept, sample.keyframes[i], false);
    Result<StoredKeyframe> read = store.readKeyframe(sample.keyframes[i].node_id);
    ASSERT_TRUE(read) << read.error();
    expectSameKeyframe(*read, sample.keyframes[i], true);
  }
  ASSERT_EQ(store.loops().size(), sample.loops.size());
  for (size_t i = 0; i < sample.loops.size(); ++i) {
    // In memory without its pairs; they are read back from the record.
    StoredLoop kept = store.loops()[i];
    EXPECT_TRUE(kept.inlier_pairs.empty());
    Result<std::vector<std::pair<int, int>>> pairs = store.readLoopPairs(i);
    ASSERT_TRUE(pairs) << pairs.error();
    kept.inlier_pairs = std::move(pairs).value();
    expectSameLoop(kept, sample.loops[i]);
  }
  EXPECT_FALSE(store.readLoopPairs(sample.loops.size()));
}

TEST(MapStore, RoundTripKeyframesAndLoops) {
  testing::TempDir tmp;
  const Sample sample;
  EXPECT_GT(
      sample.keyframes[0].keyframe.images.depth.size() + sample.keyframes[0].keyframe.images.color.size(),
      40000u);  // realistic images, not a toy blob
  auto store = openStore(tmp.path("map"), true);
  ASSERT_TRUE(store);
  EXPECT_EQ(store->recovery().keyframes, 0);
  sample.appendTo(store.get());
  expectContent(*store, sample);
  EXPECT_EQ(store->bytesOnDisk(),
            static_cast<int64_t>(std::filesystem::file_size(tmp.path("map/keyframes.log")) +
                                 std::filesystem::file_size(tmp.path("map/loops.log"))));
  EXPECT_FALSE(store->readKeyframe(6));
  EXPECT_NE(store->readKeyframe(-3).error().find("unknown node id"), std::string::npos);
}

TEST(MapStore, ReopenGivesTheSameContent) {
  testing::TempDir tmp;
  const Sample sample;
  int64_t bytes = 0;
  {
    auto store = openStore(tmp.dir());
    ASSERT_TRUE(store);
    sample.appendTo(store.get());
    bytes = store->bytesOnDisk();
  }
  for (int round = 0; round < 2; ++round) {
    auto store = openStore(tmp.dir());
    ASSERT_TRUE(store);
    const MapStoreRecovery& r = store->recovery();
    EXPECT_EQ(r.keyframes, 6);
    EXPECT_EQ(r.loops, 3);
    EXPECT_EQ(r.corrupt_records, 0);
    EXPECT_EQ(r.truncated_bytes, 0);
    EXPECT_TRUE(r.problems.empty());
    EXPECT_EQ(store->bytesOnDisk(), bytes);
    EXPECT_EQ(store->directory(), tmp.dir());
    expectContent(*store, sample);
  }
}

TEST(MapStore, LoopsAppendedTogetherReadBackLikeSingleOnes) {
  testing::TempDir tmp;
  const Sample sample;
  {
    auto store = openStore(tmp.dir(), true);
    ASSERT_TRUE(store);
    for (const auto& k : sample.keyframes) ASSERT_TRUE(store->appendKeyframe(k).ok());
    ASSERT_TRUE(store->appendLoops(sample.loops).ok());
    EXPECT_TRUE(store->appendLoops({}).ok());
    // One bad loop refuses the whole batch and writes nothing.
    EXPECT_FALSE(store->appendLoops({makeLoop(0, 1), makeLoop(0, 99)}).ok());
    EXPECT_EQ(store->loops().size(), sample.loops.size());
    expectContent(*store, sample);  // the pairs of a batch read back from their places in it
  }
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  EXPECT_EQ(store->recovery().corrupt_records, 0);
  expectContent(*store, sample);
}

TEST(MapStore, SecondOpenOfALockedDirectoryFails) {
  testing::TempDir tmp;
  {
    auto first = openStore(tmp.dir());
    ASSERT_TRUE(first);
    Result<std::unique_ptr<MapStore>> second = MapStore::open(tmp.dir());
    ASSERT_FALSE(second);
    EXPECT_NE(second.error().find("in use"), std::string::npos) << second.error();
    EXPECT_NE(second.error().find(tmp.dir()), std::string::npos) << second.error();
  }
  EXPECT_TRUE(openStore(tmp.dir()));  // released with the first store
}

TEST(MapStore, DuplicateNodeIdIsRefusedAndNothingWritten) {
  testing::TempDir tmp;
  const EncodedImages images = testing::randomImages(64, 48, 3);
  {
    auto store = openStore(tmp.dir());
    ASSERT_TRUE(store);
    ASSERT_TRUE(store->appendKeyframe(makeKeyframe(5, 0, images)).ok());
    const int64_t bytes = store->bytesOnDisk();
    Status again = store->appendKeyframe(makeKeyframe(5, 1, images));
    ASSERT_FALSE(again);
    EXPECT_NE(again.error().find("duplicate node id 5"), std::string::npos) << again.error();
    EXPECT_EQ(store->bytesOnDisk(), bytes);
    EXPECT_EQ(static_cast<int64_t>(std::filesystem::file_size(tmp.path("keyframes.log"))), bytes);
    EXPECT_EQ(store->keyframes().size(), 1u);
  }
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  EXPECT_FALSE(store->appendKeyframe(makeKeyframe(5, 0, images)));
  EXPECT_TRUE(store->appendKeyframe(makeKeyframe(6, 0, images)).ok());
}

TEST(MapStore, InvalidInputIsRefusedAndNothingWritten) {
  testing::TempDir tmp;
  const EncodedImages images = testing::randomImages(64, 48, 4);
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  ASSERT_TRUE(store->appendKeyframe(makeKeyframe(0, 0, images)).ok());
  ASSERT_TRUE(store->appendKeyframe(makeKeyframe(1, 0, images)).ok());
  const int64_t bytes = store->bytesOnDisk();

  StoredKeyframe negative = makeKeyframe(2, 0, images);
  negative.node_id = -1;
  StoredKeyframe nan_pose = makeKeyframe(2, 0, images);
  nan_pose.keyframe.T_odom_cam.translation().x() = std::nan("");
  StoredKeyframe wrong_sender = makeKeyframe(2, 0, images);
  wrong_sender.keyframe.header.sender = "robot_9";
  StoredKeyframe no_depth = makeKeyframe(2, 0, images);
  no_depth.keyframe.images.depth.clear();
  for (const StoredKeyframe* k : {&negative, &nan_pose, &wrong_sender, &no_depth}) {
    Status s = store->appendKeyframe(*k);
    EXPECT_FALSE(s);
    EXPECT_FALSE(s.error().empty());
  }
  StoredLoop nan_info = makeLoop(0, 1), unknown = makeLoop(0, 7), self = makeLoop(1, 1),
             bad_rotation = makeLoop(0, 1), negative_pair = makeLoop(1, 0), too_many_pairs = makeLoop(1, 0);
  nan_info.information(2, 2) = std::numeric_limits<double>::infinity();
  bad_rotation.T_from_to.linear()(0, 0) = 2.0;
  negative_pair.inlier_pairs[7].second = -1;
  too_many_pairs.inlier_pairs.assign(kMaxStoredLoopPairs + 1, {0, 0});
  for (const StoredLoop* l : {&nan_info, &unknown, &self, &bad_rotation, &negative_pair, &too_many_pairs})
    EXPECT_FALSE(store->appendLoop(*l));
  EXPECT_NE(store->appendLoop(negative_pair).error().find("negative feature index"), std::string::npos);
  EXPECT_NE(store->appendLoop(unknown).error().find("unknown node id 7"), std::string::npos);
  EXPECT_EQ(store->bytesOnDisk(), bytes);
  EXPECT_EQ(store->keyframes().size(), 2u);
  EXPECT_TRUE(store->loops().empty());
  EXPECT_TRUE(store->appendLoop(makeLoop(0, 1)).ok());
}

void writeManifest(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(MapStore, WrongFormatVersionIsRefusedWithAClearMessage) {
  testing::TempDir tmp;
  ASSERT_TRUE(openStore(tmp.dir()));
  writeManifest(tmp.path("MANIFEST"), "rgbdmap map store\nformat_version 2\nmessage_schema_version 1\n");
  Result<std::unique_ptr<MapStore>> store = MapStore::open(tmp.dir());
  ASSERT_FALSE(store);
  EXPECT_NE(store.error().find("format version 2"), std::string::npos) << store.error();
  EXPECT_NE(store.error().find("format version 1 only"), std::string::npos) << store.error();

  writeManifest(tmp.path("MANIFEST"), "rgbdmap map store\nformat_version 1\nmessage_schema_version 7\n");
  store = MapStore::open(tmp.dir());
  ASSERT_FALSE(store);
  EXPECT_NE(store.error().find("schema version 7"), std::string::npos) << store.error();

  writeManifest(tmp.path("MANIFEST"), "something else\n");
  EXPECT_NE(MapStore::open(tmp.dir()).error().find("not a map store manifest"), std::string::npos);

  std::filesystem::remove(tmp.path("MANIFEST"));  // logs without a manifest: refuse to guess
  EXPECT_NE(MapStore::open(tmp.dir()).error().find("no MANIFEST"), std::string::npos);
}

// A store holds Keyframe messages only, and keyframe_t is the same in every schema from
// kOldestStoredSchemaVersion on (tests/proto, ProtoSchema.*): a store written under an older schema is read
// as it is; older than that is refused with the versions it reads.
TEST(MapStore, AStoreOfAnOlderSchemaWithTheSameKeyframeMessageIsRead) {
  testing::TempDir tmp;
  const Sample sample;
  {
    Result<std::unique_ptr<MapStore>> store = openStore(tmp.dir());
    ASSERT_TRUE(store);
    sample.appendTo(store->get());
  }
  const std::string manifest = "rgbdmap map store\nformat_version 1\nmessage_schema_version ";
  writeManifest(tmp.path("MANIFEST"), manifest + std::to_string(msg::kOldestStoredSchemaVersion) + "\n");
  {
    Result<std::unique_ptr<MapStore>> store = MapStore::open(tmp.dir());
    ASSERT_TRUE(store) << store.error();
    expectContent(**store, sample);
  }
  writeManifest(tmp.path("MANIFEST"), manifest + std::to_string(msg::kOldestStoredSchemaVersion - 1) + "\n");
  Result<std::unique_ptr<MapStore>> store = MapStore::open(tmp.dir());
  ASSERT_FALSE(store);
  EXPECT_NE(store.error().find("decodes schema versions " + msg::readableStoredSchemas()), std::string::npos)
      << store.error();
}

TEST(MapStore, UnusableDirectoriesFailWithAReason) {
  testing::TempDir tmp;
  tmp.write("file", "x");
  Result<std::unique_ptr<MapStore>> store = MapStore::open(tmp.path("file"));
  ASSERT_FALSE(store);
  EXPECT_NE(store.error().find("not a directory"), std::string::npos) << store.error();
  EXPECT_FALSE(MapStore::open(""));
  EXPECT_TRUE(openStore(tmp.path("a/b/c")));  // missing parents are created
}

TEST(MapStore, ReadsDuringAppendsFromAnotherThread) {
  testing::TempDir tmp;
  const EncodedImages images = testing::randomImages(160, 120, 5);
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  std::vector<StoredKeyframe> all;
  for (int64_t id = 0; id < 60; ++id) all.push_back(makeKeyframe(id, 0, images, 100));
  for (int64_t id = 0; id < 10; ++id) ASSERT_TRUE(store->appendKeyframe(all[id]).ok());
  std::atomic<bool> done{false};
  std::atomic<int> bad_reads{0}, reads{0};
  std::thread reader([&] {
    for (int i = 0; !done || i < 200; ++i) {
      Result<StoredKeyframe> k = store->readKeyframe(i % 10);
      if (!k || k->keyframe.images.depth != images.depth || k->keyframe.keypoints.size() != 100) ++bad_reads;
      ++reads;
    }
  });
  for (int64_t id = 10; id < 60; ++id) EXPECT_TRUE(store->appendKeyframe(all[id]).ok());
  done = true;
  reader.join();
  EXPECT_EQ(bad_reads, 0);
  EXPECT_GE(reads, 200);
  for (int64_t id = 0; id < 60; ++id) EXPECT_TRUE(store->readKeyframe(id)) << id;
}

}  // namespace
}  // namespace rgbdmap
