// Residual, Jacobian and API checks of the pose graph (rgbdmap_pose_graph).
#include <ceres/autodiff_cost_function.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_cost.hpp"
#include "rgbdmap/graph/pose_graph_residual.hpp"

namespace rgbdmap {
namespace {

SE3 randomPose(std::mt19937* rng, double t_scale, double r_scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 xi;
  for (int i = 0; i < 6; ++i) xi[i] = n(*rng) * (i < 3 ? t_scale : r_scale);
  return se3::exp(xi);
}

Mat6 randomInformation(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Mat6 A;
  for (int i = 0; i < 36; ++i) A(i) = u(*rng);
  return A * A.transpose() + 0.5 * Mat6::Identity();
}

TEST(PoseGraphResidual, MatchesWhitenedSe3Log) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    const SE3 T_map_from = randomPose(&rng, 3.0, 1.0), T_map_to = randomPose(&rng, 3.0, 1.0);
    const SE3 T_from_to = randomPose(&rng, 3.0, 1.0);
    Mat6 sqrt_info;
    ASSERT_TRUE(sqrtInformation(randomInformation(&rng), &sqrt_info));
    double p_from[7], p_to[7];
    packPose(T_map_from, p_from);
    packPose(T_map_to, p_to);
    Vec6 r;
    RelativePoseResidual(T_from_to, sqrt_info)(p_from, p_to, r.data());
    const Vec6 expected = sqrt_info * se3::log(T_from_to.inverse() * T_map_from.inverse() * T_map_to);
    EXPECT_LT((r - expected).norm(), 1e-9 * (1.0 + expected.norm())) << trial;
  }
}

TEST(PoseGraphResidual, ZeroAtTruthAndSmallAngleSeriesIsContinuous) {
  std::mt19937 rng(4);
  const SE3 T_map_from = randomPose(&rng, 2.0, 1.0), T_from_to = randomPose(&rng, 2.0, 1.0);
  double p_from[7], p_to[7];
  packPose(T_map_from, p_from);
  packPose(T_map_from * T_from_to, p_to);
  Vec6 r;
  RelativePoseResidual(T_from_to, Mat6::Identity())(p_from, p_to, r.data());
  EXPECT_LT(r.norm(), 1e-12);
  // Just below the switch to the J_l^-1 series (theta^2 = 1e-4) it agrees with the closed form.
  const Vec3 v(0.3, -1.2, 0.7), w = Vec3(1, 2, 3).normalized() * 0.0099;
  const double theta = w.norm(), half = 0.5 * theta;
  const double coef = (1.0 - half * std::cos(half) / std::sin(half)) / (theta * theta);
  const Vec3 closed_form = v - 0.5 * w.cross(v) + coef * w.cross(w.cross(v));
  EXPECT_LT((RelativePoseResidual::leftJacobianInverseTimes<double>(w, v) - closed_form).norm(), 1e-11);
}

// Basalt style: the autodiff Jacobian against central differences.
TEST(PoseGraphResidual, AutodiffJacobianMatchesNumeric) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T_map_from = randomPose(&rng, 2.0, 0.8);
    const SE3 T_from_to = randomPose(&rng, 2.0, 0.8);
    // Near the measurement (the usual case) and far from it.
    const SE3 T_map_to =
        T_map_from * T_from_to * randomPose(&rng, trial % 2 ? 0.5 : 0.01, trial % 2 ? 0.5 : 0.01);
    Mat6 sqrt_info;
    ASSERT_TRUE(sqrtInformation(randomInformation(&rng), &sqrt_info));
    auto* functor = new RelativePoseResidual(T_from_to, sqrt_info);
    ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 7, 7> cost(functor);
    double p[2][7];
    packPose(T_map_from, p[0]);
    packPose(T_map_to, p[1]);
    const double* params[2] = {p[0], p[1]};
    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> J[2];
    double* jacobians[2] = {J[0].data(), J[1].data()};
    Vec6 r;
    ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
    const double h = 1e-6;
    for (int block = 0; block < 2; ++block) {
      for (int i = 0; i < 7; ++i) {
        double plus[2][7], minus[2][7];
        std::copy(&p[0][0], &p[0][0] + 14, &plus[0][0]);
        std::copy(&p[0][0], &p[0][0] + 14, &minus[0][0]);
        plus[block][i] += h;
        minus[block][i] -= h;
        Vec6 rp, rm;
        (*functor)(plus[0], plus[1], rp.data());
        (*functor)(minus[0], minus[1], rm.data());
        const Vec6 numeric = (rp - rm) / (2 * h);
        EXPECT_LT((J[block].col(i) - numeric).norm(), 1e-6 * (1.0 + numeric.norm()))
            << "trial " << trial << " block " << block << " param " << i;
      }
    }
  }
}

using Manifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
using Jac67 = Eigen::Matrix<double, 6, 7, Eigen::RowMajor>;
using Jac76 = Eigen::Matrix<double, 7, 6, Eigen::RowMajor>;

// The analytic cost against numeric differences on the manifold (x [+] delta) and against autodiff, both in
// the tangent space the solver uses.
TEST(PoseGraphResidual, AnalyticJacobianMatchesNumericAndAutodiffOnManifold) {
  std::mt19937 rng(7);
  const Manifold manifold;
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T_map_from = randomPose(&rng, 2.0, 0.8), T_from_to = randomPose(&rng, 2.0, 0.8);
    const double spread = trial % 2 ? 0.6 : 1e-3;
    const SE3 T_map_to = T_map_from * T_from_to * randomPose(&rng, spread, spread);
    Mat6 sqrt_info;
    ASSERT_TRUE(sqrtInformation(randomInformation(&rng), &sqrt_info));
    const RelativePoseCost analytic(T_from_to, sqrt_info);
    const ceres::AutoDiffCostFunction<RelativePoseResidual, 6, 7, 7> autodiff(
        new RelativePoseResidual(T_from_to, sqrt_info));
    double p[2][7];
    packPose(T_map_from, p[0]);
    packPose(T_map_to, p[1]);
    const double* params[2] = {p[0], p[1]};
    Jac67 Ja[2], Jd[2];
    double* ja[2] = {Ja[0].data(), Ja[1].data()};
    double* jd[2] = {Jd[0].data(), Jd[1].data()};
    Vec6 ra, rd;
    ASSERT_TRUE(analytic.Evaluate(params, ra.data(), ja));
    ASSERT_TRUE(autodiff.Evaluate(params, rd.data(), jd));
    EXPECT_LT((ra - rd).norm(), 1e-9);
    for (int b = 0; b < 2; ++b) {
      Jac76 plus_jacobian;
      manifold.PlusJacobian(p[b], plus_jacobian.data());
      const Mat6 J_analytic = Ja[b] * plus_jacobian, J_autodiff = Jd[b] * plus_jacobian;
      Mat6 J_numeric;
      for (int i = 0; i < 6; ++i) {
        const double h = 1e-6;
        Vec6 delta = Vec6::Zero();
        double moved[2][7];
        Vec6 r_plus, r_minus;
        for (double sign : {1.0, -1.0}) {
          std::copy(&p[0][0], &p[0][0] + 14, &moved[0][0]);
          delta[i] = sign * h;
          manifold.Plus(p[b], delta.data(), moved[b]);
          const double* mp[2] = {moved[0], moved[1]};
          analytic.Evaluate(mp, sign > 0 ? r_plus.data() : r_minus.data(), nullptr);
        }
        J_numeric.col(i) = (r_plus - r_minus) / (2 * h);
      }
      EXPECT_LT((J_analytic - J_numeric).norm(), 1e-6 * (1.0 + J_numeric.norm())) << trial << " block " << b;
      EXPECT_LT((J_analytic - J_autodiff).norm(), 1e-9 * (1.0 + J_autodiff.norm()))
          << trial << " block " << b;
    }
  }
}

// The information is given for a left perturbation of the measurement; mapped by the adjoint, the whitened
// chi2 of the residual equals d^T * info * d to first order.
TEST(PoseGraphResidual, LeftPerturbationInformationMapsToResidualFrame) {
  std::mt19937 rng(6);
  const SE3 T_true = randomPose(&rng, 2.0, 0.8);
  const Mat6 info = randomInformation(&rng);
  Mat6 sqrt_info;
  ASSERT_TRUE(sqrtInformation(residualInformation(T_true, info), &sqrt_info));
  Vec6 d;
  d << 1e-5, -2e-5, 3e-5, 2e-5, 1e-5, -1e-5;
  const SE3 T_meas = se3::exp(d) * T_true;
  double p_from[7], p_to[7];
  packPose(SE3::Identity(), p_from);
  packPose(T_true, p_to);
  Vec6 r;
  RelativePoseResidual(T_meas, sqrt_info)(p_from, p_to, r.data());
  const double expected = d.dot(info * d);
  EXPECT_NEAR(r.squaredNorm(), expected, 1e-3 * expected);
}

TEST(PoseGraphApi, RejectsBadInput) {
  PoseGraph graph;
  ASSERT_TRUE(graph.addNode(1, 0, SE3::Identity()).ok());
  ASSERT_TRUE(graph.addNode(2, 0, SE3::Identity()).ok());
  EXPECT_FALSE(graph.addNode(1, 0, SE3::Identity()).ok());
  SE3 bad = SE3::Identity();
  bad.translation().x() = std::nan("");
  EXPECT_FALSE(graph.addNode(3, 0, bad).ok());
  PoseGraphEdge e;
  e.id = 7, e.from = 1, e.to = 2;
  EXPECT_TRUE(graph.addEdge(e).ok());
  EXPECT_FALSE(graph.addEdge(e).ok()) << "duplicate edge id";
  e.id = 8, e.to = 9;
  EXPECT_FALSE(graph.addEdge(e).ok()) << "unknown node";
  e.to = 1;
  EXPECT_FALSE(graph.addEdge(e).ok()) << "self edge";
  e.to = 2;
  e.information = Mat6::Identity();
  e.information(5, 5) = -1.0;
  EXPECT_FALSE(graph.addEdge(e).ok()) << "not positive definite";
  e.information = Mat6::Identity();
  e.information(0, 1) = 0.5;
  EXPECT_FALSE(graph.addEdge(e).ok()) << "asymmetric";
  EXPECT_FALSE(graph.setFixed(42).ok());
  EXPECT_FALSE(graph.setPose(42, SE3::Identity()).ok());
}

TEST(PoseGraphApi, FixesTheFirstNodeWhenNothingIsFixed) {
  PoseGraph graph;
  SE3 T_first = se3::exp((Vec6() << 1, 2, 3, 0.1, 0.2, 0.3).finished());
  ASSERT_TRUE(graph.addNode(10, 0, T_first).ok());
  ASSERT_TRUE(graph.addNode(11, 0, SE3::Identity()).ok());
  PoseGraphEdge e;
  e.id = 1, e.from = 10, e.to = 11;
  e.T_from_to.translation() = Vec3(1, 0, 0);
  ASSERT_TRUE(graph.addEdge(e).ok());
  auto report = graph.optimize(PoseGraphConfig{});
  ASSERT_TRUE(report.ok()) << report.error();
  EXPECT_TRUE(graph.pose(10)->isApprox(T_first, 1e-12));
  EXPECT_TRUE(graph.pose(11)->isApprox(T_first * e.T_from_to, 1e-6));
  EXPECT_EQ(graph.components().size(), 1u);
}

TEST(PoseGraphApi, MeasuredPosesNearComposeMeasurementsAlongFewestHopsOverEnabledEdges) {
  // A chain 0..9 of true poses; edges point either way; the estimates are all wrong (identity), so only
  // the measurements can give the answer. A loop 9 -> 0 makes 9 one hop from 0.
  std::mt19937 rng(11);
  std::vector<SE3> truth;
  PoseGraph graph;
  for (int i = 0; i < 10; ++i) {
    truth.push_back(i == 0 ? SE3::Identity() : truth.back() * randomPose(&rng, 0.3, 0.1));
    ASSERT_TRUE(graph.addNode(i, 0, SE3::Identity()).ok());
  }
  int64_t edge_id = 0;
  const auto addEdge = [&](int from, int to, EdgeKind kind) {
    PoseGraphEdge e;
    e.id = edge_id++;
    e.from = from, e.to = to, e.kind = kind;
    e.T_from_to = truth[from].inverse() * truth[to];
    EXPECT_TRUE(graph.addEdge(e).ok());
    return e.id;
  };
  for (int i = 0; i + 1 < 10; ++i)
    i % 2 ? addEdge(i + 1, i, EdgeKind::kOdometry) : addEdge(i, i + 1, EdgeKind::kOdometry);
  const int64_t loop = addEdge(9, 0, EdgeKind::kLoop);

  const auto near5 = graph.measuredPosesNear(5, 2, 100);
  EXPECT_EQ(near5.size(), 5u);  // 3..7
  for (const auto& [id, T] : near5) {
    EXPECT_LE(std::abs(id - 5), 2);
    EXPECT_TRUE(T.isApprox(truth[5].inverse() * truth[id], 1e-9)) << id;
  }
  const auto near0 = graph.measuredPosesNear(0, 1, 100);
  ASSERT_EQ(near0.size(), 3u);  // 0, 1 and, over the loop, 9
  EXPECT_TRUE(near0.at(9).isApprox(truth[9], 1e-9));
  EXPECT_TRUE(near0.at(0).isApprox(SE3::Identity()));
  EXPECT_EQ(graph.measuredPosesNear(0, 100, 4).size(), 4u) << "node cap";
  EXPECT_TRUE(graph.measuredPosesNear(42, 3, 100).empty()) << "unknown source";
  EXPECT_TRUE(graph.measuredPosesNear(0, 0, 100).size() == 1u) << "no hops: the source alone";

  // A disabled loop is no path: 9 is then 9 hops away, composed over the whole chain.
  std::map<int64_t, SE3> poses;
  for (int i = 0; i < 10; ++i) poses[i] = SE3::Identity();
  graph.applyOptimized(poses, {loop});
  EXPECT_EQ(graph.measuredPosesNear(0, 1, 100).size(), 2u);
  const auto all = graph.measuredPosesNear(0, 9, 100);
  ASSERT_EQ(all.size(), 10u);
  EXPECT_TRUE(all.at(9).isApprox(truth[9], 1e-9));
}

TEST(PoseGraphApi, EmptyGraphOptimizes) {
  PoseGraph graph;
  EXPECT_TRUE(graph.optimize(PoseGraphConfig{}).ok());
  EXPECT_TRUE(graph.components().empty());
}

}  // namespace
}  // namespace rgbdmap
