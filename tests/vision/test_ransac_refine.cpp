#include <random>

#include <gtest/gtest.h>

#include "test_cameras.hpp"

#include "rgbdmap/vision/pose_refiner.hpp"
#include "rgbdmap/vision/ransac.hpp"

namespace rgbdmap {
namespace {

// Random scene points seen by both cameras, with pixel and depth noise, and a share of gross outliers.
std::vector<PointMatch> makeMatches(const SE3& T_cur_ref, int n, double outlier_share, std::mt19937& rng,
                                    std::vector<bool>* is_outlier, double px_noise = 0.5) {
  const PinholeCamera cam(testing::idealPinhole());
  std::uniform_real_distribution<double> u(0, 640), v(0, 480), z(0.8, 4.0);
  std::normal_distribution<double> npx(0, px_noise), nz(0, 1);
  std::vector<PointMatch> out;
  while (static_cast<int>(out.size()) < n) {
    const Vec3 p_ref = cam.backProject({u(rng), v(rng)}, z(rng));
    Vec3 p_cur = T_cur_ref * p_ref;
    auto px = cam.project(p_cur);
    if (!px || !cam.inImage(*px)) continue;
    PointMatch m;
    m.p_ref = p_ref;
    const bool outlier = std::uniform_real_distribution<double>(0, 1)(rng) < outlier_share;
    if (outlier) {  // a wrong match: some other point of the current image
      p_cur = cam.backProject({u(rng), v(rng)}, z(rng));
      px = cam.project(p_cur);
    }
    const double z_noisy = p_cur.z() + 0.0015 * p_cur.z() * p_cur.z() * nz(rng);
    m.px_cur = *px + Eigen::Vector2d(npx(rng), npx(rng));
    m.p_cur = cam.backProject(m.px_cur, z_noisy);
    m.px_ref = *cam.project(p_ref);
    out.push_back(m);
    is_outlier->push_back(outlier);
  }
  return out;
}

SE3 testMotion() {
  Vec6 xi;
  xi << 0.12, -0.05, 0.2, 0.04, -0.08, 0.03;
  return se3::exp(xi);
}

TEST(Ransac, RecoversPoseWithHalfOutliers) {
  std::mt19937 rng(7);
  std::vector<bool> outlier;
  const SE3 T_true = testMotion();
  const auto matches = makeMatches(T_true, 400, 0.5, rng, &outlier);
  const PinholeCamera cam(testing::idealPinhole());
  const RansacResult r = ransacRigid(matches, cam, RansacConfig{});
  ASSERT_TRUE(r.success);
  EXPECT_LT((r.T_cur_ref.translation() - T_true.translation()).norm(), 0.02);
  EXPECT_LT(se3::rotationAngle(r.T_cur_ref.inverse() * T_true), 0.01);
  int wrong = 0;
  for (int i : r.inliers) wrong += outlier[i];
  EXPECT_LE(wrong, 5) << "outliers accepted as inliers";
  EXPECT_GT(r.inliers.size(), 150u);
}

TEST(Ransac, FailsCleanlyOnPureOutliers) {
  std::mt19937 rng(8);
  std::vector<bool> outlier;
  const auto matches = makeMatches(testMotion(), 200, 1.0, rng, &outlier);
  const RansacResult r = ransacRigid(matches, PinholeCamera(testing::idealPinhole()), RansacConfig{});
  EXPECT_FALSE(r.success);
}

TEST(Ransac, TooFewMatches) {
  std::mt19937 rng(9);
  std::vector<bool> outlier;
  const auto matches = makeMatches(testMotion(), 5, 0.0, rng, &outlier);
  EXPECT_FALSE(ransacRigid(matches, PinholeCamera(testing::idealPinhole()), RansacConfig{}).success);
}

TEST(Refine, ImprovesOnRansacAndRejectsOutliers) {
  std::mt19937 rng(10);
  std::vector<bool> outlier;
  const SE3 T_true = testMotion();
  const auto matches = makeMatches(T_true, 400, 0.3, rng, &outlier);
  const PinholeCamera cam(testing::idealPinhole());
  Vec6 perturb;
  perturb << 0.02, -0.01, 0.015, 0.01, 0.005, -0.01;
  const RefineResult r = refinePose(matches, se3::exp(perturb) * T_true, cam, RefineConfig{});
  EXPECT_LT((r.T_cur_ref.translation() - T_true.translation()).norm(), 0.005);
  EXPECT_LT(se3::rotationAngle(r.T_cur_ref.inverse() * T_true), 0.002);
  int kept_outliers = 0;
  for (size_t i = 0; i < matches.size(); ++i) kept_outliers += r.inlier_mask[i] && outlier[i];
  EXPECT_LE(kept_outliers, 3);
  EXPECT_GT(r.inliers, 230);
  // The information matrix is symmetric positive definite.
  EXPECT_TRUE(r.information.isApprox(r.information.transpose(), 1e-9));
  EXPECT_GT(r.information.ldlt().vectorD().minCoeff(), 0.0);
}

TEST(Refine, AnalyticJacobianMatchesNumeric) {
  std::mt19937 rng(11);
  std::vector<bool> outlier;
  const SE3 T = testMotion();
  const auto matches = makeMatches(T, 20, 0.0, rng, &outlier);
  const PinholeCamera cam(testing::idealPinhole());
  const RefineConfig config;
  for (const auto& m : matches) {
    Eigen::Vector3d r0;
    Eigen::Matrix<double, 3, 6> J;
    ASSERT_EQ(matchResidual(m, T, cam, config, &r0, &J), 3);
    Eigen::Matrix<double, 3, 6> Jn;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Vec6 d = Vec6::Zero();
      d(k) = h;
      Eigen::Vector3d rp, rm;
      matchResidual(m, se3::exp(d) * T, cam, config, &rp, nullptr);
      matchResidual(m, se3::exp(-d) * T, cam, config, &rm, nullptr);
      Jn.col(k) = (rp - rm) / (2 * h);
    }
    // Depth sigma depends on the predicted depth; the analytic Jacobian treats sigma as constant,
    // so compare the reprojection rows tightly and the depth row loosely.
    EXPECT_LT((J.topRows<2>() - Jn.topRows<2>()).norm(), 1e-4 * (1 + J.norm()));
    EXPECT_LT((J.row(2) - Jn.row(2)).norm(), 0.1 * (1 + J.row(2).norm()));
  }
}

TEST(Refine, WorksWithoutCurrentDepth) {
  std::mt19937 rng(12);
  std::vector<bool> outlier;
  const SE3 T_true = testMotion();
  auto matches = makeMatches(T_true, 200, 0.0, rng, &outlier, 0.3);
  for (auto& m : matches) m.p_cur = Vec3::Zero();  // 2-D observations only
  const RefineResult r = refinePose(matches, T_true, PinholeCamera(testing::idealPinhole()), RefineConfig{});
  EXPECT_EQ(r.inliers, 200);
  EXPECT_LT((r.T_cur_ref.translation() - T_true.translation()).norm(), 0.01);
}

}  // namespace
}  // namespace rgbdmap

namespace rgbdmap {
namespace {

TEST(Refine, DegenerateInputKeepsAFullSizeMask) {
  // One to three random matches under random starting poses make the normal equations singular or
  // indefinite; the mask must still cover every match (regression: an early return left it empty and the
  // odometry indexed past its end).
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0), z(0.5, 4.0), px(0, 640);
  const PinholeCamera cam(testing::idealPinhole());
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<PointMatch> matches(1 + trial % 3);
    for (auto& m : matches) {
      m.p_ref = Vec3(u(rng), u(rng), z(rng));
      m.p_cur = Vec3(u(rng), u(rng), z(rng));
      m.px_cur = Eigen::Vector2d(px(rng), px(rng));
      m.px_ref = Eigen::Vector2d(px(rng), px(rng));
    }
    Vec6 xi;
    xi << u(rng), u(rng), u(rng), 3 * u(rng), 3 * u(rng), 3 * u(rng);
    const RefineResult r = refinePose(matches, se3::exp(xi), cam, RefineConfig{});
    ASSERT_EQ(r.inlier_mask.size(), matches.size()) << "trial " << trial;
    ASSERT_TRUE(se3::isValid(r.T_cur_ref, 1e-6)) << "trial " << trial;
  }
}

}  // namespace
}  // namespace rgbdmap
