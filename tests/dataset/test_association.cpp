#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "rgbdmap/dataset/association.hpp"

namespace rgbdmap {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(Associate, JitteredStreamsMatchTheirNearestNeighbour) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.004, 0.004);
  std::vector<double> gt, est;
  for (int i = 0; i < 1000; ++i) gt.push_back(100.0 + 0.01 * i);                // 100 Hz
  for (int i = 0; i < 300; ++i) est.push_back(100.0 + i / 30.0 + jitter(rng));  // 30 Hz, +-4 ms
  const auto m = associate(est, gt, 0.02);
  ASSERT_EQ(m.size(), est.size());
  for (size_t k = 0; k < m.size(); ++k) {
    EXPECT_EQ(m[k].a, k);  // sorted by a's time
    const double nearest = std::round((est[k] - 100.0) / 0.01);
    EXPECT_EQ(m[k].b, static_cast<size_t>(nearest)) << k;
  }
}

TEST(Associate, GreedySmallestDifferenceFirstEachUsedOnce) {
  const auto m = associate({0.0, 0.125}, {0.0625 + 0.03125}, 0.25);  // b is 0.09375 from a0, 0.03125 from a1
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].a, 1u);
}

TEST(Associate, UnsortedInputNonFiniteStampsAndTolerance) {
  const double inf = std::numeric_limits<double>::infinity();
  const auto m = associate({3.0, kNaN, 1.0, 2.0}, {2.0078125, 0.9921875, inf, 3.015625, 5.0}, 0.02);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].a, 2u);  // t = 1
  EXPECT_EQ(m[0].b, 1u);
  EXPECT_EQ(m[1].a, 3u);  // t = 2
  EXPECT_EQ(m[1].b, 0u);
  EXPECT_EQ(m[2].a, 0u);  // t = 3
  EXPECT_EQ(m[2].b, 3u);
  EXPECT_TRUE(associate({1.0}, {1.0}, 0.0).empty());
  EXPECT_TRUE(associate({1.0}, {1.0}, kNaN).empty());
  EXPECT_TRUE(associate({1.0}, {1.5}, 0.5).empty());  // strict, as associate.py
}

}  // namespace
}  // namespace rgbdmap
