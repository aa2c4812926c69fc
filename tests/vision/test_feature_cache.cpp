// FeatureCache: the most recently used features stay in RAM, the others are read back through
// the loader; features a caller still holds are never loaded twice; a failed read is null and counted.
#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "rgbdmap/vision/feature_cache.hpp"

namespace rgbdmap {
namespace {

/// n features whose first descriptor byte and depth name the keyframe.
FrameFeatures featuresOf(int64_t id, int n = 5) {
  FrameFeatures f;
  f.descriptors = cv::Mat(n, 32, CV_8U, cv::Scalar(static_cast<int>(id % 256)));
  for (int i = 0; i < n; ++i) {
    f.keypoints.emplace_back(static_cast<float>(i), static_cast<float>(id), 31.0f);
    f.px.emplace_back(i, static_cast<double>(id));
    f.depth_m.push_back(1.0 + static_cast<double>(id));
    f.p_cam.emplace_back(0.0, 0.0, 1.0 + static_cast<double>(id));
  }
  return f;
}

struct CountingLoader {
  std::atomic<int> calls{0};
  FeatureCache::Loader loader() {
    return [this](int64_t id) {
      ++calls;
      return Result<FrameFeatures>(featuresOf(id));
    };
  }
};

TEST(FeatureCache, KeepsTheMostRecentlyUsedAndReadsTheOthersBack) {
  CountingLoader disk;
  FeatureCache cache(3, disk.loader());
  for (int64_t id = 0; id < 5; ++id) cache.add(id, std::make_shared<const FrameFeatures>(featuresOf(id)));
  FeatureCacheStats s = cache.stats();
  EXPECT_EQ(s.keyframes, 5u);
  EXPECT_EQ(s.resident, 3u);
  EXPECT_EQ(s.evictions, 2u);
  EXPECT_EQ(disk.calls, 0);

  // 4 is resident: no read. Then 0 was dropped: read back, and the right one.
  ASSERT_TRUE(cache.get(4));
  EXPECT_EQ(disk.calls, 0);
  const auto zero = cache.get(0);
  ASSERT_TRUE(zero);
  EXPECT_EQ(disk.calls, 1);
  EXPECT_EQ(zero->depth_m[0], 1.0);
  EXPECT_EQ(zero->descriptors.at<uint8_t>(0, 0), 0);
  // 0 and 4 are the two most recent now: 3 is still resident, 2 was dropped for 0.
  ASSERT_TRUE(cache.get(3));
  EXPECT_EQ(disk.calls, 1);
  const auto two = cache.get(2);
  ASSERT_TRUE(two);
  EXPECT_EQ(two->p_cam[0].z(), 3.0);
  EXPECT_EQ(disk.calls, 2);
  s = cache.stats();
  EXPECT_EQ(s.loads, 2u);
  EXPECT_EQ(s.resident, 3u);
  EXPECT_EQ(s.load_failures, 0u);
  EXPECT_FALSE(cache.get(99)) << "an unknown id";
  EXPECT_FALSE(cache.contains(99));
}

TEST(FeatureCache, FeaturesACallerHoldsAreNotLoadedASecondTime) {
  CountingLoader disk;
  FeatureCache cache(1, disk.loader());
  cache.add(0, std::make_shared<const FrameFeatures>(featuresOf(0)));
  const auto held = cache.get(0);
  cache.add(1, std::make_shared<const FrameFeatures>(featuresOf(1)));  // drops 0 from the cache
  EXPECT_EQ(cache.stats().resident, 1u);
  const auto again = cache.get(0);
  EXPECT_EQ(again.get(), held.get()) << "the same object while a caller holds it";
  EXPECT_EQ(disk.calls, 0);
}

TEST(FeatureCache, AFailedOrWrongReadGivesNullAndIsCounted) {
  std::atomic<bool> fail{true};
  FeatureCache cache(1, [&](int64_t id) {
    if (fail) return Result<FrameFeatures>::failure("record " + std::to_string(id) + " unreadable");
    return Result<FrameFeatures>(featuresOf(id, 7));  // not the 5 features it had
  });
  cache.add(0, std::make_shared<const FrameFeatures>(featuresOf(0)));
  cache.add(1, std::make_shared<const FrameFeatures>(featuresOf(1)));
  EXPECT_FALSE(cache.get(0));
  fail = false;
  EXPECT_FALSE(cache.get(0)) << "features of another size are not this keyframe's";
  const FeatureCacheStats s = cache.stats();
  EXPECT_EQ(s.load_failures, 2u);
  EXPECT_EQ(s.loads, 0u);
  EXPECT_TRUE(cache.get(1)) << "the resident one is unaffected";
}

TEST(FeatureCache, WithoutALimitNothingIsDropped) {
  FeatureCache cache(0, {});
  for (int64_t id = 0; id < 100; ++id) cache.add(id, std::make_shared<const FrameFeatures>(featuresOf(id)));
  EXPECT_EQ(cache.stats().resident, 100u);
  for (int64_t id = 0; id < 100; ++id) ASSERT_TRUE(cache.get(id));
  EXPECT_EQ(cache.stats().loads, 0u);
}

TEST(FeatureCache, ThreadsReadingAndAddingAtOnceGetTheRightFeatures) {
  CountingLoader disk;
  FeatureCache cache(8, disk.loader());
  for (int64_t id = 0; id < 64; ++id) cache.add(id, std::make_shared<const FrameFeatures>(featuresOf(id)));
  std::atomic<int> wrong{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < 2000; ++i) {
        const int64_t id = (i * 7 + t * 13) % 64;
        const auto f = cache.get(id);
        if (!f || f->depth_m[0] != 1.0 + static_cast<double>(id)) ++wrong;
      }
    });
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(wrong, 0);
  EXPECT_LE(cache.stats().resident, 8u);
  EXPECT_GT(cache.stats().loads, 0u);
}

}  // namespace
}  // namespace rgbdmap
