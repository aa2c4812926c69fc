// Sanity checks of ATE / RPE on the real fr1_rpy ground truth (skipped when ../shared/data is absent).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/common_test_util.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "test_data.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::knownTransform;

/// The fr1_rpy ground truth moved into another world frame, 3 ms late, with isotropic position noise.
Trajectory perturbedFr1Rpy(const Trajectory& gt, double sigma) {
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 1.0);
  Trajectory est;
  for (const auto& p : gt) {
    SE3 T_est_cam = knownTransform().inverse() * p.T_world_cam;
    T_est_cam.translation() += sigma * Vec3(noise(rng), noise(rng), noise(rng));
    est.push_back({p.timestamp + 0.003, T_est_cam});
  }
  return est;
}

RGBDMAP_TEST_TIER("EvaluationReal.*", "e2e sanitize");
TEST(EvaluationReal, Fr1RpyGroundTruthTransformed) {
  RGBDMAP_REQUIRE_SHARED_DATA("tum_fr1_rpy_first250");
  const auto gt = readTumTrajectory(testing::sharedDataDir("tum_fr1_rpy_first250") + "/groundtruth.txt");
  ASSERT_TRUE(gt) << gt.error();
  const auto ate = computeAte(*gt, perturbedFr1Rpy(*gt, 0.0));
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_EQ(ate->matched, gt->size());
  EXPECT_LT(ate->rmse, 1e-9);
  EXPECT_LT((ate->T_gt_est.matrix() - knownTransform().matrix()).norm(), 1e-6);
  const auto rpe = computeRpe(*gt, perturbedFr1Rpy(*gt, 0.0));
  ASSERT_TRUE(rpe) << rpe.error();
  EXPECT_LT(rpe->trans_max, 1e-9);
}

TEST(EvaluationReal, Fr1RpyGroundTruthTransformedWithNoise) {
  RGBDMAP_REQUIRE_SHARED_DATA("tum_fr1_rpy_first250");
  const auto gt = readTumTrajectory(testing::sharedDataDir("tum_fr1_rpy_first250") + "/groundtruth.txt");
  ASSERT_TRUE(gt) << gt.error();
  const double sigma = 0.01;
  const Trajectory est = perturbedFr1Rpy(*gt, sigma);
  const auto ate = computeAte(*gt, est);
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_NEAR(ate->rmse, sigma * std::sqrt(3.0), 0.1 * sigma * std::sqrt(3.0));
  // fr1_rpy moves only a few cm, so 1 cm noise leaves the rotation loose (about a degree); the transform
  // must still agree with the true one where the trajectory is.
  const Vec3 c_est = knownTransform().inverse() * gt->front().T_world_cam.translation();
  EXPECT_LT((ate->T_gt_est * c_est - knownTransform() * c_est).norm(), 0.01);
  EXPECT_LT(se3::rotationAngle(ate->T_gt_est.inverse() * knownTransform()) * 180 / EIGEN_PI, 3.0);

  const auto rpe = computeRpe(*gt, est);  // position noise at both ends of a pair: sqrt(2) sigma per axis
  ASSERT_TRUE(rpe) << rpe.error();
  EXPECT_GT(rpe->pairs, 900u);
  EXPECT_NEAR(rpe->trans_rmse, sigma * std::sqrt(6.0), 0.1 * sigma * std::sqrt(6.0));
  EXPECT_LT(rpe->rot_max_deg, 1e-6);
}

}  // namespace
}  // namespace rgbdmap
