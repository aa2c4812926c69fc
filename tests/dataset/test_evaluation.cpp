#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "common/common_test_util.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/dataset/evaluation_json.hpp"

namespace rgbdmap {
namespace {

using testing::contains;

SE3 pose(const Mat3& R, const Vec3& t) {
  SE3 T = SE3::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

Mat3 yaw(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }

/// n poses at t = t0 + i * dt.
Trajectory sample(int n, double dt, const std::function<SE3(double)>& at, double t0 = 0.0) {
  Trajectory out;
  for (int i = 0; i < n; ++i) out.push_back({t0 + i * dt, at(i * dt)});
  return out;
}

Trajectory fromPositions(const std::vector<Vec3>& p) {
  Trajectory out;
  for (size_t i = 0; i < p.size(); ++i) out.push_back({static_cast<double>(i), pose(Mat3::Identity(), p[i])});
  return out;
}

/// A helix with changing orientation: well conditioned for alignment.
SE3 helix(double t) { return pose(yaw(0.5 * t), Vec3(std::cos(t), std::sin(t), 0.2 * t)); }

using testing::knownTransform;

TEST(Summarize, MedianMeanRmseMinMax) {
  const ErrorStats even = summarize({3, 1, 2, 10});
  EXPECT_EQ(even.count, 4u);
  EXPECT_DOUBLE_EQ(even.median, 2.5);  // numpy: mean of the two middle values
  EXPECT_DOUBLE_EQ(even.mean, 4.0);
  EXPECT_DOUBLE_EQ(even.rmse, std::sqrt(114.0 / 4));
  EXPECT_DOUBLE_EQ(even.std, std::sqrt(114.0 / 4 - 16.0));
  EXPECT_EQ(even.min, 1.0);
  EXPECT_EQ(even.max, 10.0);
  EXPECT_DOUBLE_EQ(summarize({5, 1, 3}).median, 3.0);
  EXPECT_EQ(summarize({}).count, 0u);
}

TEST(Ate, RigidlyTransformedEstimateHasZeroErrorAndRecoversTheTransform) {
  const Trajectory gt = sample(100, 0.1, helix);
  Trajectory est = gt;
  for (auto& p : est) p.T_world_cam = knownTransform().inverse() * p.T_world_cam;  // est world != gt world
  const auto ate = computeAte(gt, est);
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_EQ(ate->matched, 100u);
  EXPECT_LT(ate->rmse, 1e-9);
  EXPECT_LT(ate->max, 1e-9);
  EXPECT_TRUE(ate->alignment_unique);
  EXPECT_LT((ate->T_gt_est.matrix() - knownTransform().matrix()).norm(), 1e-9);
}

TEST(Ate, ConstantOffsetIsAlignedAway) {
  const Trajectory gt = sample(50, 0.1, helix);
  Trajectory est = gt;
  for (auto& p : est) p.T_world_cam.translation().z() += 0.3;
  const auto ate = computeAte(gt, est);
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_LT(ate->rmse, 1e-9);
  EXPECT_LT((ate->T_gt_est.translation() - Vec3(0, 0, -0.3)).norm(), 1e-9);
}

TEST(Ate, AlternatingOffsetOnOneAxisGivesThatOffset) {
  // Square corners in z = 0, estimate alternately +-0.05 in z. The signed corner sum is zero, so no rotation
  // or translation reduces the error: every point keeps |0.05|.
  const std::vector<Vec3> corners = {{1, 1, 0}, {-1, 1, 0}, {-1, -1, 0}, {1, -1, 0}};
  std::vector<Vec3> shifted;
  for (size_t i = 0; i < corners.size(); ++i)
    shifted.push_back(corners[i] + Vec3(0, 0, i % 2 ? -0.05 : 0.05));
  const auto ate = computeAte(fromPositions(corners), fromPositions(shifted));
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_NEAR(ate->rmse, 0.05, 1e-12);
  EXPECT_NEAR(ate->mean, 0.05, 1e-12);
  EXPECT_NEAR(ate->median, 0.05, 1e-12);
  EXPECT_NEAR(ate->min, 0.05, 1e-12);
  EXPECT_NEAR(ate->std, 0.0, 1e-6);
  EXPECT_LT((ate->T_gt_est.matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-12);
}

TEST(Ate, HandComputedTriangle) {
  // Equilateral triangle with unit circumradius; the estimate is 10% larger about the centroid and then
  // moved rigidly. The best rigid fit leaves 0.1 m at each vertex; a similarity fit removes it (s = 1/1.1).
  const double h = std::sqrt(3.0) / 2;
  const std::vector<Vec3> tri = {{1, 0, 0}, {-0.5, h, 0}, {-0.5, -h, 0}};
  std::vector<Vec3> big;
  for (const Vec3& p : tri) big.push_back(knownTransform().inverse() * (1.1 * p));
  const auto ate = computeAte(fromPositions(tri), fromPositions(big));
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_EQ(ate->matched, 3u);
  EXPECT_NEAR(ate->rmse, 0.1, 1e-12);
  EXPECT_NEAR(ate->median, 0.1, 1e-12);
  EXPECT_NEAR(ate->max, 0.1, 1e-12);
  EXPECT_LT((ate->T_gt_est.linear() - knownTransform().linear()).norm(), 1e-9);
  AteOptions sim3;
  sim3.with_scale = true;
  const auto scaled = computeAte(fromPositions(tri), fromPositions(big), sim3);
  ASSERT_TRUE(scaled) << scaled.error();
  EXPECT_LT(scaled->rmse, 1e-12);
  EXPECT_NEAR(scaled->scale, 1 / 1.1, 1e-12);
}

TEST(Ate, JitteredTimestampsAreAssociated) {
  const Trajectory gt = sample(300, 0.01, helix, 1000.0);  // 100 Hz
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.003, 0.003);
  Trajectory est;
  for (int i = 0; i < 90; ++i) {
    const double t = 1000.0 + i / 30.0 + jitter(rng);
    est.push_back({t, helix(t - 1000.0)});
  }
  const auto ate = computeAte(gt, est);
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_EQ(ate->matched, 90u);
  EXPECT_LT(ate->max, 0.01);  // <= 5 ms of motion at ~1 m/s
}

TEST(Ate, StraightLineIsValidButFlaggedNotUnique) {
  const Trajectory gt = sample(20, 0.1, [](double t) { return pose(Mat3::Identity(), Vec3(t, 0, 0)); });
  const auto ate = computeAte(gt, gt);
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_LT(ate->rmse, 1e-12);
  EXPECT_FALSE(ate->alignment_unique);
}

TEST(Ate, RejectsBadInput) {
  const Trajectory gt = sample(10, 0.1, helix);
  Trajectory est = gt;
  est[3].T_world_cam.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(contains(computeAte(gt, est).error(), "estimated pose 3")) << computeAte(gt, est).error();
  est = gt;
  est[4].timestamp = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(contains(computeAte(gt, est).error(), "non-finite timestamp"));
  est = gt;
  est[5].T_world_cam.linear() *= 2.0;
  EXPECT_TRUE(contains(computeAte(gt, est).error(), "non-rotation"));
  EXPECT_TRUE(contains(computeAte(gt, sample(10, 0.1, helix, 50.0)).error(), "only 0 estimated poses"));
  EXPECT_TRUE(contains(computeAte(gt, Trajectory(gt.begin(), gt.begin() + 2)).error(), "only 2"));
  EXPECT_TRUE(contains(computeAte({}, gt).error(), "ground-truth trajectory is empty"));
  AteOptions bad;
  bad.max_dt = 0;
  EXPECT_TRUE(contains(computeAte(gt, gt, bad).error(), "max_dt"));
}

TEST(Rpe, ZeroForIdenticalAndForGloballyTransformedEstimates) {
  const Trajectory gt = sample(60, 0.1, helix);
  Trajectory moved = gt;
  for (auto& p : moved) p.T_world_cam = knownTransform() * p.T_world_cam;
  for (const Trajectory& est : {gt, moved}) {
    const auto rpe = computeRpe(gt, est);
    ASSERT_TRUE(rpe) << rpe.error();
    EXPECT_EQ(rpe->pairs, 50u);  // i = 0..49 have a partner 1 s later
    EXPECT_LT(rpe->trans_max, 1e-9);
    EXPECT_LT(rpe->rot_max_deg, 1e-6);
  }
}

TEST(Rpe, ConstantVelocityWithScaleDrift) {
  // Constant body twist: 0.5 m/s forward while yawing at 0.2 rad/s; the estimate's speed is 10% high. Over
  // 1 s both turn 0.2 rad and the true chord is 2 (v / w) sin(w / 2); the estimate's chord is 10% longer
  // along the same direction, so every pair is off by 0.1 * 2 * 2.5 * sin(0.1) m and not at all in rotation.
  Vec6 xi_gt, xi_est;
  xi_gt << 0.5, 0, 0, 0, 0, 0.2;
  xi_est << 0.55, 0, 0, 0, 0, 0.2;
  const auto rpe = computeRpe(sample(51, 0.1, [&](double t) { return se3::exp(t * xi_gt); }),
                              sample(51, 0.1, [&](double t) { return se3::exp(t * xi_est); }));
  ASSERT_TRUE(rpe) << rpe.error();
  const double expected = 0.1 * 2 * 2.5 * std::sin(0.1);
  EXPECT_EQ(rpe->pairs, 41u);
  EXPECT_NEAR(rpe->trans_rmse, expected, 1e-9);
  EXPECT_NEAR(rpe->trans_median, expected, 1e-9);
  EXPECT_NEAR(rpe->trans_min, expected, 1e-9);
  EXPECT_NEAR(rpe->trans_max, expected, 1e-9);
  EXPECT_LT(rpe->rot_max_deg, 1e-6);
}

TEST(Rpe, YawRateDrift) {
  auto truth = [](double t) { return pose(yaw(0.2 * t), Vec3::Zero()); };
  auto drifting = [](double t) { return pose(yaw(0.22 * t), Vec3::Zero()); };
  const auto rpe = computeRpe(sample(31, 0.1, truth), sample(31, 0.1, drifting));
  ASSERT_TRUE(rpe) << rpe.error();
  EXPECT_EQ(rpe->pairs, 21u);
  EXPECT_NEAR(rpe->rot_rmse_deg, 0.02 * 180 / EIGEN_PI, 1e-9);
  EXPECT_NEAR(rpe->rot_max_deg, 0.02 * 180 / EIGEN_PI, 1e-9);
  EXPECT_LT(rpe->trans_max, 1e-12);
}

TEST(Rpe, SingleDisplacedPoseMedianAndMax) {
  auto truth = [](double t) { return pose(Mat3::Identity(), Vec3(t, 0, 0)); };
  const Trajectory gt = sample(51, 0.1, truth);
  Trajectory est = gt;
  est[20].T_world_cam.translation().z() += 0.2;  // in pairs (10, 20) and (20, 30) only
  const auto rpe = computeRpe(gt, est);
  ASSERT_TRUE(rpe) << rpe.error();
  ASSERT_EQ(rpe->pairs, 41u);
  EXPECT_NEAR(rpe->trans_max, 0.2, 1e-12);
  EXPECT_NEAR(rpe->trans_median, 0.0, 1e-12);
  EXPECT_NEAR(rpe->trans_mean, 0.4 / 41, 1e-12);
  EXPECT_NEAR(rpe->trans_rmse, 0.2 * std::sqrt(2.0 / 41), 1e-12);
}

TEST(Rpe, RejectsBadInputAndShortTrajectories) {
  const Trajectory gt = sample(60, 0.1, helix);
  EXPECT_TRUE(contains(computeRpe(gt, Trajectory(gt.begin(), gt.begin() + 5)).error(), "no pair"));
  Trajectory est = gt;
  est[7].T_world_cam.linear()(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(contains(computeRpe(gt, est).error(), "estimated pose 7"));
  RpeOptions bad;
  bad.delta = -1;
  EXPECT_TRUE(contains(computeRpe(gt, gt, bad).error(), "delta"));
  RpeOptions short_delta;
  short_delta.delta = 0.1;
  const auto per_frame = computeRpe(gt, gt, short_delta);
  ASSERT_TRUE(per_frame) << per_frame.error();
  EXPECT_EQ(per_frame->pairs, 59u);
}

TEST(Rpe, JitteredThirtyHertzEstimateKeepsNearlyAllPairs) {
  const Trajectory gt = sample(600, 0.01, helix, 1000.0);  // 6 s at 100 Hz
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.004, 0.004);
  Trajectory est;
  for (int i = 0; i < 175; ++i) {
    const double t = 1000.0 + i / 30.0 + jitter(rng);
    est.push_back(
        {t, helix(std::round((t - 1000.0) / 0.01) * 0.01)});  // the pose of the gt sample it matches
  }
  const auto rpe = computeRpe(gt, est);
  ASSERT_TRUE(rpe) << rpe.error();
  EXPECT_GE(rpe->pairs, 140u);  // 145 poses have a partner ~1 s later
  EXPECT_LE(rpe->pairs, 146u);
  EXPECT_LT(rpe->trans_max, 1e-9);
}

TEST(EvaluationFormat, TextAndJson) {
  AteResult ate;
  ate.matched = 3;
  ate.rmse = 0.1;
  ate.max = std::numeric_limits<double>::quiet_NaN();
  const std::string text = formatAte(ate);
  EXPECT_TRUE(contains(text, "ate_matched 3\n"));
  EXPECT_TRUE(contains(text, "ate_rmse_m 0.1\n"));
  EXPECT_TRUE(
      contains(text, "ate_T_gt_est 0.000000 0.000000 0.000000 0.000000 0.000000 0.000000 1.000000\n"));
  const std::string json = compactJson(ateJson(ate));
  EXPECT_TRUE(contains(json, "{\"matched\":3,\"rmse_m\":0.1,")) << json;
  EXPECT_TRUE(contains(json, "\"max_m\":null")) << json;
  EXPECT_TRUE(contains(json, "\"q_xyzw\":[0,0,0,1]}}")) << json;
  RpeResult rpe;
  rpe.pairs = 7;
  rpe.rot_rmse_deg = 1.5;
  EXPECT_TRUE(contains(formatRpe(rpe), "rpe_pairs 7\nrpe_delta_s 1\n"));
  EXPECT_TRUE(contains(formatRpe(rpe), "rpe_rot_rmse_deg 1.5\n"));
  EXPECT_TRUE(contains(compactJson(rpeJson(rpe)), "\"rot_rmse_deg\":1.5,"));
}

}  // namespace
}  // namespace rgbdmap
