#include <random>

#include <gtest/gtest.h>

#include "rgbdmap/common/rigid_align.hpp"

namespace rgbdmap {
namespace {

TEST(RigidAlign, RecoversKnownTransform) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-2, 2);
  Vec6 xi;
  xi << 0.5, -1.0, 2.0, 0.3, -1.2, 2.0;
  const SE3 T = se3::exp(xi);
  std::vector<Vec3> src, dst;
  for (int i = 0; i < 50; ++i) {
    src.emplace_back(u(rng), u(rng), u(rng));
    dst.push_back(T * src.back());
  }
  const auto est = alignPointSets(src, dst);
  ASSERT_TRUE(est);
  EXPECT_LT((est->matrix() - T.matrix()).norm(), 1e-9);
}

TEST(RigidAlign, HandComputedTranslationOnly) {
  const std::vector<Vec3> src = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  const std::vector<Vec3> dst = {{1, 2, 3}, {2, 2, 3}, {1, 3, 3}};
  const auto est = alignPointSets(src, dst);
  ASSERT_TRUE(est);
  EXPECT_TRUE(est->linear().isIdentity(1e-12));
  EXPECT_TRUE(est->translation().isApprox(Vec3(1, 2, 3), 1e-12));
}

TEST(RigidAlign, RejectsDegenerateInput) {
  EXPECT_FALSE(alignPointSets({{0, 0, 0}, {1, 1, 1}}, {{0, 0, 0}, {1, 1, 1}}));  // too few
  EXPECT_FALSE(
      alignPointSets({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}));  // collinear
  EXPECT_FALSE(
      alignPointSets({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 0, 0}, {1, 0, std::nan("")}, {0, 1, 0}}));
  EXPECT_FALSE(alignPointSets({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 0, 0}, {1, 0, 0}}));  // size mismatch
}

}  // namespace
}  // namespace rgbdmap
