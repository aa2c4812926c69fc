// The global bundle adjustment schedule (server/backend): due every N keyframes once the map grew by a
// fraction of itself, after large changes when grown, all changed maps when asked; backoff after fruitless
// runs, reset by one that helps; no global BA past the keyframe limit.
#include <gtest/gtest.h>

#include "rgbdmap/backend/global_bundle_schedule.hpp"

namespace rgbdmap {
namespace {

GlobalBundleSchedule::KeyframeCount constantSize(size_t n) {
  return [n](int) { return n; };
}

void addKeyframes(GlobalBundleSchedule* s, int map, int n) {
  for (int i = 0; i < n; ++i) s->keyframeAdded(map);
}

TEST(GlobalBundleSchedule, AMapIsDueEveryNKeyframesOnceItGrewByTheFraction) {
  GlobalBundleSchedule s({/*every_keyframes=*/10, /*min_growth_fraction=*/0.1, /*max_keyframes=*/0});
  addKeyframes(&s, 7, 9);
  EXPECT_TRUE(s.dueAfterBatch(false, false, constantSize(50)).empty());
  s.keyframeAdded(7);
  EXPECT_EQ(s.dueAfterBatch(false, false, constantSize(50)), std::set<int>{7});
  // 10 added is not 10 % of a 200-keyframe map: it waits for 20.
  EXPECT_TRUE(s.dueAfterBatch(false, false, constantSize(200)).empty());
  addKeyframes(&s, 7, 10);
  EXPECT_EQ(s.dueAfterBatch(false, false, constantSize(200)), std::set<int>{7});
}

TEST(GlobalBundleSchedule, AStartedRunCountsGrowthFromZeroAndClearsTheChange) {
  GlobalBundleSchedule s({10, 0.0, 0});
  addKeyframes(&s, 1, 12);
  s.mapChanged(2);
  EXPECT_EQ(s.changed(), (std::set<int>{1, 2}));
  s.started(1);
  EXPECT_EQ(s.changed(), std::set<int>{2});
  EXPECT_TRUE(s.dueAfterBatch(false, false, constantSize(12)).empty());
}

TEST(GlobalBundleSchedule, AskingGivesEveryChangedMapAndLargeChangesOnlyGrownOnes) {
  GlobalBundleSchedule s({0, 0.5, 0});
  addKeyframes(&s, 1, 2);                                                // of 10: not grown by half
  addKeyframes(&s, 2, 6);                                                // of 10: grown
  EXPECT_TRUE(s.dueAfterBatch(false, false, constantSize(10)).empty());  // every_keyframes 0: only on change
  EXPECT_EQ(s.dueAfterBatch(false, true, constantSize(10)), std::set<int>{2});
  EXPECT_EQ(s.dueAfterBatch(true, false, constantSize(10)), (std::set<int>{1, 2}));
}

TEST(GlobalBundleSchedule, FruitlessRunsDoubleTheGrowthUpTo64AndAHelpfulOneResetsIt) {
  GlobalBundleSchedule s({1, 0.1, 0});
  const GlobalRunOutcome fruitless{true, 2.0, 1.99};
  int backoff = 0;
  for (int i = 0; i < 8; ++i) {
    const auto verdict = s.finished(3, fruitless);
    EXPECT_TRUE(verdict.fruitless);
    backoff = verdict.backoff;
  }
  EXPECT_EQ(backoff, 64);
  addKeyframes(&s, 3, 63);  // 64 x 10 % of 10 keyframes = 64
  EXPECT_FALSE(s.grownEnough(3, 10));
  s.keyframeAdded(3);
  EXPECT_TRUE(s.grownEnough(3, 10));
  EXPECT_FALSE(s.finished(3, {true, 2.0, 1.5}).fruitless);  // out of time but the error fell by 25 %
  EXPECT_EQ(s.backoff(3), 1);
  EXPECT_EQ(s.finished(3, {false, 2.0, 2.0}).backoff, 1);  // converged: never fruitless
}

TEST(GlobalBundleSchedule, MapsPastTheKeyframeLimitAreOverItAndZeroMeansNoLimit) {
  EXPECT_TRUE(GlobalBundleSchedule({50, 0.1, 4000}).overLimit(4001));
  EXPECT_FALSE(GlobalBundleSchedule({50, 0.1, 4000}).overLimit(4000));
  EXPECT_FALSE(GlobalBundleSchedule({50, 0.1, 0}).overLimit(1000000));
}

}  // namespace
}  // namespace rgbdmap
