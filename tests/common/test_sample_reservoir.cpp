// SampleReservoir (rgbdmap_common): exact up to its capacity, bounded memory and unbiased quantiles beyond.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "rgbdmap/common/sample_reservoir.hpp"

namespace rgbdmap {
namespace {

TEST(SampleReservoir, EmptyIsZero) {
  const SampleReservoir r;
  EXPECT_EQ(r.count(), 0u);
  EXPECT_EQ(r.median(), 0.0);
  EXPECT_EQ(r.quantile(0.9), 0.0);
  EXPECT_EQ(r.max(), 0.0);
  EXPECT_TRUE(r.samples().empty());
}

TEST(SampleReservoir, ExactAndInOrderUpToItsCapacity) {
  SampleReservoir r(100);
  std::vector<double> values;
  std::mt19937 rng(3);
  for (int i = 0; i < 100; ++i) {
    values.push_back(std::uniform_real_distribution<double>(0.0, 50.0)(rng));
    r.add(values.back());
  }
  EXPECT_EQ(r.samples(), values);
  EXPECT_DOUBLE_EQ(r.median(), quantileOf(values, 0.5));
  EXPECT_DOUBLE_EQ(r.quantile(0.9), quantileOf(values, 0.9));
  EXPECT_DOUBLE_EQ(r.max(), *std::max_element(values.begin(), values.end()));
}

TEST(SampleReservoir, QuantileInterpolates) {
  EXPECT_DOUBLE_EQ(quantileOf({4.0, 1.0, 3.0, 2.0}, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(quantileOf({1.0, 2.0, 3.0, 4.0, 5.0}, 0.9), 4.6);
  EXPECT_DOUBLE_EQ(quantileOf({7.0}, 0.9), 7.0);
}

// A million samples from a skewed distribution: memory stays at the capacity, count and max are exact and
// median/p90 agree with the whole stream's within sampling noise.
TEST(SampleReservoir, BoundedAndUnbiasedBeyondItsCapacity) {
  SampleReservoir r(4096);
  std::vector<double> all;
  std::mt19937 rng(7);
  std::lognormal_distribution<double> dist(3.0, 0.5);  // ~20 ms median with a long tail, like ingest times
  for (int i = 0; i < 1000000; ++i) {
    all.push_back(dist(rng));
    r.add(all.back());
  }
  EXPECT_EQ(r.count(), all.size());
  EXPECT_EQ(r.samples().size(), 4096u);
  EXPECT_DOUBLE_EQ(r.max(), *std::max_element(all.begin(), all.end()));
  const double median = quantileOf(all, 0.5), p90 = quantileOf(all, 0.9);
  EXPECT_NEAR(r.median(), median, 0.03 * median);
  EXPECT_NEAR(r.quantile(0.9), p90, 0.03 * p90);
}

TEST(SampleReservoir, KeepsLateSamplesToo) {
  SampleReservoir r(1000);
  for (int i = 0; i < 100000; ++i) r.add(i < 50000 ? 1.0 : 2.0);  // the run gets slower half way
  EXPECT_NEAR(r.quantile(0.25), 1.0, 1e-12);
  EXPECT_NEAR(r.quantile(0.75), 2.0, 1e-12);
  const std::vector<double> kept = r.samples();
  EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end())) << "arrival order";
}

}  // namespace
}  // namespace rgbdmap
