// A failed map store comes back by itself: after an I/O error (a full disk, simulated with a file size
// limit: the writes really fail part-way) appends stop, recover() fails while the cause lasts, and once
// space is back it cuts the logs to their last acknowledged record and takes appends again; nothing stored
// before is lost and the directory reopens clean.
#include <filesystem>

#include <gtest/gtest.h>

#include "common/file_size_limit.hpp"
#include "common/temp_dir.hpp"
#include "store/map_store_test_util.hpp"

namespace rgbdmap {
namespace {

namespace fs = std::filesystem;
using testing::makeKeyframe;
using testing::makeLoop;
using testing::openStore;

EncodedImages imagesFor(uint32_t seed) { return testing::randomImages(32, 24, seed); }

/// Three keyframes and a loop, then an append that fails on a limit just past the current end.
void fillAndFail(MapStore* store, const std::string& dir) {
  for (int64_t id = 0; id < 3; ++id)
    ASSERT_TRUE(store->appendKeyframe(makeKeyframe(id, 0, imagesFor(1), 20)));
  ASSERT_TRUE(store->appendLoop(makeLoop(0, 2)));
  const auto end = fs::file_size(dir + "/keyframes.log");
  testing::FileSizeLimit full(end + 500);
  ASSERT_TRUE(full.ok());
  ASSERT_FALSE(store->appendKeyframe(makeKeyframe(3, 0, imagesFor(2), 20)));
  EXPECT_EQ(fs::file_size(dir + "/keyframes.log"), end);
}

TEST(MapStoreRetry, FailedStoreRecoversOnceSpaceIsBack) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  auto store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  EXPECT_FALSE(store->health().failed);
  fillAndFail(store.get(), tmp.dir());
  MapStoreHealth h = store->health();
  EXPECT_TRUE(h.failed);
  EXPECT_EQ(h.failures, 1u);
  EXPECT_NE(h.error.find("cannot write"), std::string::npos) << h.error;
  const auto end = fs::file_size(tmp.path("keyframes.log"));
  {
    testing::FileSizeLimit still_full(end + 500);
    ASSERT_TRUE(still_full.ok());
    EXPECT_FALSE(store->recover());  // the probe does not fit
    EXPECT_FALSE(store->appendKeyframe(makeKeyframe(3, 0, imagesFor(2), 20)));
  }
  EXPECT_EQ(fs::file_size(tmp.path("keyframes.log")), end);  // the probe's bytes are cut off again
  h = store->health();
  EXPECT_TRUE(h.failed);
  EXPECT_EQ(h.recover_attempts, 1u);
  EXPECT_EQ(h.recoveries, 0u);
  EXPECT_NE(h.error.find("recovery failed"), std::string::npos) << h.error;

  ASSERT_TRUE(store->recover());  // space is back
  h = store->health();
  EXPECT_FALSE(h.failed);
  EXPECT_EQ(h.error, "");
  EXPECT_EQ(h.failures, 1u);
  EXPECT_EQ(h.recover_attempts, 2u);
  EXPECT_EQ(h.recoveries, 1u);
  ASSERT_TRUE(store->appendKeyframe(makeKeyframe(3, 0, imagesFor(2), 20)));
  ASSERT_TRUE(store->appendLoop(makeLoop(1, 3)));
  EXPECT_TRUE(store->recover());  // not failed: nothing to do
  EXPECT_EQ(store->health().recover_attempts, 2u);

  store.reset();
  store = openStore(tmp.dir());
  ASSERT_TRUE(store);
  EXPECT_EQ(store->recovery().keyframes, 4);
  EXPECT_EQ(store->recovery().loops, 2);
  EXPECT_TRUE(store->recovery().problems.empty());
  for (int64_t id = 0; id < 4; ++id) EXPECT_TRUE(store->readKeyframe(id)) << id;
}

TEST(MapStoreRetry, FailedLoopAppendStopsKeyframesTooUntilRecovered) {
  const testing::QuietLog quiet;
  testing::TempDir tmp;
  auto store = openStore(tmp.dir(), true);
  ASSERT_TRUE(store);
  for (int64_t id = 0; id < 2; ++id)
    ASSERT_TRUE(store->appendKeyframe(makeKeyframe(id, 0, imagesFor(1), 20)));
  {
    testing::FileSizeLimit full(100);  // the loop log is empty: a 432-byte record does not fit
    ASSERT_TRUE(full.ok());
    ASSERT_FALSE(store->appendLoops({makeLoop(0, 1)}));
  }
  EXPECT_EQ(fs::file_size(tmp.path("loops.log")), 0u);
  EXPECT_FALSE(store->appendKeyframe(makeKeyframe(2, 0, imagesFor(1), 20)));
  ASSERT_TRUE(store->recover());
  ASSERT_TRUE(store->appendLoops({makeLoop(0, 1)}));
  ASSERT_TRUE(store->appendKeyframe(makeKeyframe(2, 0, imagesFor(1), 20)));
  EXPECT_EQ(store->health().recoveries, 1u);
}

}  // namespace
}  // namespace rgbdmap
