// Bundle adjustment residuals: analytic Jacobians against numeric differences through the manifold's Plus
// (to 1e-6 relative), the manifold's Plus/Minus round trip, and the whitened residual values.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rgbdmap/ba/ba_cost.hpp"
#include "rgbdmap/ba/landmark_map.hpp"

namespace rgbdmap {
namespace {

struct Case {
  double pose[7];
  double point[3];
  double w[3];  ///< rolling-shutter rotation
};

Case randomCase(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Case c;
  const SE3 T = se3::exp((Vec6() << u(rng), u(rng), u(rng), u(rng), u(rng), u(rng)).finished());
  poseToParams(T, c.pose);
  // A point 1-4 m in front of the camera, expressed in the map frame.
  const Vec3 p_kf(u(rng), u(rng), 2.5 + 1.5 * u(rng));
  Eigen::Map<Vec3> point(c.point);
  point = T.inverse() * p_kf;
  for (double& w : c.w) w = 0.05 * u(rng);
  return c;
}

/// Analytic tangent Jacobians (ambient * PlusJacobian) against central differences through Plus.
template <int Rows>
void checkJacobians(const ceres::CostFunction& cost, const Case& c) {
  BaPoseManifold manifold;
  const double* params[3] = {c.pose, c.point, c.w};
  double r[Rows];
  double J_pose[Rows * 7], J_point[Rows * 3], J_w[Rows * 3];
  double* jacobians[3] = {J_pose, J_point, J_w};
  ASSERT_TRUE(cost.Evaluate(params, r, jacobians));
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
  manifold.PlusJacobian(c.pose, P.data());
  const Eigen::Matrix<double, Rows, 6> analytic_pose =
      Eigen::Map<Eigen::Matrix<double, Rows, 7, Eigen::RowMajor>>(J_pose) * P;
  const double h = 1e-6;
  for (int i = 0; i < 6; ++i) {
    double plus[7], minus[7], rp[Rows], rm[Rows];
    Vec6 d = Vec6::Zero();
    d(i) = h;
    manifold.Plus(c.pose, d.data(), plus);
    d(i) = -h;
    manifold.Plus(c.pose, d.data(), minus);
    const double* pp[3] = {plus, c.point, c.w};
    const double* pm[3] = {minus, c.point, c.w};
    ASSERT_TRUE(cost.Evaluate(pp, rp, nullptr));
    ASSERT_TRUE(cost.Evaluate(pm, rm, nullptr));
    for (int row = 0; row < Rows; ++row) {
      const double numeric = (rp[row] - rm[row]) / (2 * h);
      EXPECT_NEAR(analytic_pose(row, i), numeric, 1e-6 * std::max(1.0, std::abs(numeric)))
          << "pose " << row << "," << i;
    }
  }
  // The point (block 1) and the rolling-shutter rotation (block 2): plain central differences.
  for (int block = 1; block <= 2; ++block) {
    const double* x = params[block];
    const double* J = block == 1 ? J_point : J_w;
    for (int i = 0; i < 3; ++i) {
      double plus[3] = {x[0], x[1], x[2]}, minus[3] = {x[0], x[1], x[2]};
      plus[i] += h;
      minus[i] -= h;
      double rp[Rows], rm[Rows];
      const double* pp[3] = {c.pose, c.point, c.w};
      const double* pm[3] = {c.pose, c.point, c.w};
      pp[block] = plus;
      pm[block] = minus;
      ASSERT_TRUE(cost.Evaluate(pp, rp, nullptr));
      ASSERT_TRUE(cost.Evaluate(pm, rm, nullptr));
      for (int row = 0; row < Rows; ++row) {
        const double numeric = (rp[row] - rm[row]) / (2 * h);
        EXPECT_NEAR(J[row * 3 + i], numeric, 1e-6 * std::max(1.0, std::abs(numeric)))
            << "block " << block << " row " << row << " col " << i;
      }
    }
  }
}

TEST(BaCost, ReprojectionJacobiansMatchNumeric) {
  std::mt19937 rng(3);
  for (int n = 0; n < 50; ++n) {
    const Case c = randomCase(rng);
    const ReprojectionCost cost(BaIntrinsics{}, {Eigen::Vector2d(300.0, 200.0), 1.44, -0.3, 0.0, 0.01});
    checkJacobians<2>(cost, c);
  }
}

TEST(BaCost, ReprojectionDepthJacobiansMatchNumeric) {
  std::mt19937 rng(4);
  for (int n = 0; n < 50; ++n) {
    const Case c = randomCase(rng);
    const ReprojectionDepthCost cost(BaIntrinsics{}, {Eigen::Vector2d(350.0, 260.0), 1.2, 0.4, 2.3, 0.01});
    checkJacobians<3>(cost, c);
  }
}

TEST(BaCost, ResidualsAreWhitenedProjectionAndInverseDepth) {
  const BaIntrinsics k;
  SE3 T = SE3::Identity();
  T.translation() = Vec3(0.1, -0.2, 0.3);
  double pose[7];
  poseToParams(T, pose);
  const Vec3 p_kf(0.5, -0.25, 2.0);
  const Vec3 p_map = T.inverse() * p_kf;
  const Eigen::Vector2d px(k.fx * 0.25 + k.cx + 2.0, k.fy * -0.125 + k.cy - 1.0);  // 2 px right, 1 px up
  const BaMeasurement m{px, 2.0, 0.25, 2.5, 0.01};
  const ReprojectionDepthCost cost(k, m);
  const Vec3 no_rs = Vec3::Zero();
  const double* params[3] = {pose, p_map.data(), no_rs.data()};
  double r[3];
  ASSERT_TRUE(cost.Evaluate(params, r, nullptr));
  EXPECT_NEAR(r[0], -1.0, 1e-9);
  EXPECT_NEAR(r[1], 0.5, 1e-9);
  EXPECT_NEAR(r[2], (1.0 / 2.0 - 1.0 / 2.5) / 0.01, 1e-9);
  const ObservationResidual o = observationResidual(k, T, p_map, no_rs, m);
  EXPECT_TRUE(o.in_front);
  EXPECT_EQ(o.rows, 3);
  EXPECT_NEAR(o.chi2, 1.0 + 0.25 + 100.0, 1e-6);
  EXPECT_NEAR(o.reprojection_px.x(), -2.0, 1e-9);
  // With a rolling-shutter rotation about the camera's x axis, the row a quarter below the middle saw the
  // point turned by 0.25 w: p - 0.25 (w x p).
  const Vec3 w(0.02, 0.0, 0.0);
  const double* params_rs[3] = {pose, p_map.data(), w.data()};
  ASSERT_TRUE(cost.Evaluate(params_rs, r, nullptr));
  const Vec3 p_rs = p_kf - 0.25 * w.cross(p_kf);
  EXPECT_NEAR(r[1], (k.fy * p_rs.y() / p_rs.z() + k.cy - px.y()) / 2.0, 1e-9);
  // Behind the camera: no residual, and the cost refuses the step.
  const Vec3 behind = T.inverse() * Vec3(0.0, 0.0, -1.0);
  EXPECT_FALSE(observationResidual(k, T, behind, no_rs, m).in_front);
  const double* bad[3] = {pose, behind.data(), no_rs.data()};
  EXPECT_FALSE(cost.Evaluate(bad, r, nullptr));
}

TEST(BaCost, ManifoldPlusMinusRoundTrip) {
  BaPoseManifold m;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (int n = 0; n < 20; ++n) {
    const Case c = randomCase(rng);
    const Vec6 d = (Vec6() << u(rng), u(rng), u(rng), u(rng), u(rng), u(rng)).finished();
    double y[7];
    ASSERT_TRUE(m.Plus(c.pose, d.data(), y));
    Vec6 back;
    ASSERT_TRUE(m.Minus(y, c.pose, back.data()));
    EXPECT_LT((back - d).norm(), 1e-9);
    // Plus is a left perturbation: T(y) = exp(d) * T(x).
    EXPECT_TRUE(paramsToPose(y).isApprox(se3::exp(d) * paramsToPose(c.pose), 1e-9));
  }
}

TEST(BaCost, RollingShutterPriorIsCentredOnTheMotionsPrediction) {
  // A camera turning about its y axis at 1.5 rad/s, keyframes 0.1 s apart, a 20 ms readout: 0.03 rad.
  SE3 T_prev_cur = SE3::Identity();
  T_prev_cur.linear() = Eigen::AngleAxisd(0.15, Vec3::UnitY()).toRotationMatrix();
  T_prev_cur.translation() = Vec3(0.05, 0.0, 0.01);
  const Vec3 predicted = predictedRollingShutter(T_prev_cur, 0.1, 0.02);
  EXPECT_LT((predicted - Vec3(0.0, 0.03, 0.0)).norm(), 1e-12);
  // No prediction without a readout time (a global shutter) or a usable time step.
  EXPECT_EQ(predictedRollingShutter(T_prev_cur, 0.1, 0.0), Vec3::Zero());
  EXPECT_EQ(predictedRollingShutter(T_prev_cur, 0.0, 0.02), Vec3::Zero());
  EXPECT_EQ(predictedRollingShutter(T_prev_cur, -0.1, 0.02), Vec3::Zero());
  EXPECT_EQ(predictedRollingShutter(T_prev_cur, std::nan(""), 0.02), Vec3::Zero());
  EXPECT_EQ(predictedRollingShutter(T_prev_cur, 2.0, 0.02), Vec3::Zero());
  // The prior's residual is the distance from that centre, whitened, with the identity Jacobian / sigma.
  const RollingShutterPrior prior(0.0025, predicted);
  const double w[3] = {0.001, 0.03, -0.002};
  const double* params[1] = {w};
  double r[3], J[9];
  double* jacobians[1] = {J};
  ASSERT_TRUE(prior.Evaluate(params, r, jacobians));
  EXPECT_NEAR(r[0], 0.001 / 0.0025, 1e-12);
  EXPECT_NEAR(r[1], 0.0, 1e-12);
  EXPECT_NEAR(r[2], -0.002 / 0.0025, 1e-12);
  EXPECT_NEAR(J[0], 1.0 / 0.0025, 1e-9);
  EXPECT_NEAR(J[1], 0.0, 1e-12);
}

}  // namespace
}  // namespace rgbdmap
