#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "common/common_test_util.hpp"
#include "rgbdmap/common/alignment.hpp"

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
