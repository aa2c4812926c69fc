#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "common/common_test_util.hpp"
#include "rgbdmap/common/alignment.hpp"
#include "rgbdmap/common/association.hpp"

namespace rgbdmap {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using testing::contains;

using testing::knownTransform;

std::vector<Vec3> randomPoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  std::vector<Vec3> out;
  for (int i = 0; i < n; ++i) out.emplace_back(u(rng), u(rng), u(rng));
  return out;
}

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

TEST(Alignment, RecoversKnownRigidTransform) {
  const SE3 T_gt_est = knownTransform();
  const std::vector<Vec3> gt = randomPoints(20, 1);
  std::vector<Vec3> est;
  for (const Vec3& p : gt) est.push_back(T_gt_est.inverse() * p);
  const auto T = alignRigid(est, gt);
  ASSERT_TRUE(T) << T.error();
  EXPECT_LT((T->matrix() - T_gt_est.matrix()).norm(), 1e-9);
}

TEST(Alignment, RecoversScaleWhenAsked) {
  const SE3 T_gt_est = knownTransform();
  const double scale = 2.5;
  const std::vector<Vec3> gt = randomPoints(10, 2);
  std::vector<Vec3> est;
  for (const Vec3& p : gt)
    est.push_back(T_gt_est.linear().transpose() * (p - T_gt_est.translation()) / scale);
  const auto a = alignUmeyama(est, gt, true);
  ASSERT_TRUE(a) << a.error();
  EXPECT_NEAR(a->scale, scale, 1e-9);
  EXPECT_LT((a->T_gt_est.matrix() - T_gt_est.matrix()).norm(), 1e-9);
  const auto rigid = alignUmeyama(est, gt, false);
  ASSERT_TRUE(rigid);
  EXPECT_EQ(rigid->scale, 1.0);
}

TEST(Alignment, PlanarPointsGiveAProperRotation) {
  // Mirror-symmetric planar sets are where an unguarded SVD returns a reflection.
  const std::vector<Vec3> est = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  std::vector<Vec3> gt;
  for (const Vec3& p : est) gt.push_back(knownTransform() * p);
  const auto T = alignRigid(est, gt);
  ASSERT_TRUE(T) << T.error();
  EXPECT_NEAR(T->linear().determinant(), 1.0, 1e-12);
  EXPECT_LT((T->matrix() - knownTransform().matrix()).norm(), 1e-9);
}

TEST(Alignment, RejectsDegenerateInput) {
  const std::vector<Vec3> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_TRUE(contains(alignRigid(two, two).error(), "at least 3"));
  const std::vector<Vec3> line = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {-3, -3, -3}};
  EXPECT_TRUE(contains(alignRigid(line, line).error(), "collinear"));
  const std::vector<Vec3> same(5, Vec3(1, 2, 3));
  EXPECT_TRUE(contains(alignRigid(same, same).error(), "collinear"));
  EXPECT_TRUE(contains(alignUmeyama(same, same, true).error(), "scale is undefined"));
  const std::vector<Vec3> pts = randomPoints(4, 3);
  EXPECT_TRUE(contains(alignRigid(pts, randomPoints(5, 3)).error(), "4 estimated but 5"));
  std::vector<Vec3> bad = pts;
  bad[2].y() = kNaN;
  EXPECT_TRUE(contains(alignRigid(bad, pts).error(), "non-finite"));
  // The lenient solver still answers for a line (rotation about it arbitrary), flagged as not unique.
  const auto lenient = solveAlignment(line, line, false);
  ASSERT_TRUE(lenient) << lenient.error();
  EXPECT_FALSE(lenient->unique);
  for (const Vec3& p : line) EXPECT_LT((lenient->T_gt_est * p - p).norm(), 1e-9);
}

}  // namespace
}  // namespace rgbdmap
