// The bundle adjuster's own Levenberg-Marquardt solver (server/ba/src/schur_bundle.hpp) against Ceres, the
// reference: on one synthetic problem with rolling shutter, depth and wrong observations, both must reach
// the same minimum (cost, outliers, poses), and both must recover the true poses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>

#include "rgbdmap/ba/ba_synth.hpp"
#include "rgbdmap/ba/bundle_adjuster.hpp"

namespace rgbdmap {
namespace {

/// Every view of every scene point by keyframes perturbed by 2 cm / 0.6 deg (the first fixed), points by
/// 1 cm, and `wrong` of the observations pointed at a random other point.
BaProblem syntheticProblem(const BaSynthScene& s, double wrong, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  BaProblem p;
  for (size_t k = 0; k < s.T_map_kf.size(); ++k) {
    SE3 T = s.T_map_kf[k];
    if (k > 0)
      T = se3::exp((Vec6() << 0.02 * n(rng), 0.02 * n(rng), 0.02 * n(rng), 0.01 * n(rng), 0.01 * n(rng),
                    0.01 * n(rng))
                       .finished()) *
          T;
    p.frames.push_back({static_cast<int64_t>(k), s.camera, T.inverse(), k == 0, Vec3::Zero(), k == 0});
  }
  for (size_t i = 0; i < s.points.size(); ++i)
    p.points.push_back({static_cast<int64_t>(i), s.points[i] + 0.01 * Vec3(n(rng), n(rng), n(rng))});
  std::uniform_int_distribution<int> any_point(0, static_cast<int>(s.points.size()) - 1);
  for (size_t k = 0; k < s.features.size(); ++k) {
    const FrameFeatures& f = *s.features[k];
    for (size_t i = 0; i < f.size(); ++i) {
      const int point = u(rng) < wrong ? any_point(rng) : s.point_of_feature[k][i];
      p.observations.push_back({static_cast<int>(k), point, f.px[i], f.keypoints[i].octave, f.depth_m[i],
                                (f.keypoints[i].pt.y - 240.0) / 480.0});
    }
  }
  return p;
}

double rmsAgainstTruth(const BaSynthScene& s, const BaSolution& x) {
  double sum = 0.0;
  for (size_t k = 0; k < s.T_map_kf.size(); ++k)
    sum += (x.T_kf_map[k].inverse().translation() - s.T_map_kf[k].translation()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(s.T_map_kf.size()));
}

TEST(SchurSolver, ReachesTheMinimumCeresReaches) {
  BaSynthConfig o;
  o.keyframes = 10;
  o.rolling_shutter_rad = 0.01;
  const BaSynthScene s = makeBaSynthScene(o);
  BaProblem problem = syntheticProblem(s, 0.05, 3);
  // The rolling-shutter rotations start at, and their priors are centred on, a prediction 10 % short of the
  // truth (the camera's motion gives one; the held anchor keeps its prediction).
  for (size_t k = 0; k < problem.frames.size(); ++k)
    problem.frames[k].w = problem.frames[k].w_prior = 0.9 * s.rolling_shutter[k];
  BaSolveConfig config;
  config.first_iterations = 20;  // both run to their convergence tests
  config.second_iterations = 30;
  config.max_time_s = 60.0;
  config.solver = BaSolver::kCeres;
  const Result<BaSolution> ceres = solveBundle(problem, config);
  config.solver = BaSolver::kSchur;
  const Result<BaSolution> own = solveBundle(problem, config);
  ASSERT_TRUE(ceres) << ceres.error();
  ASSERT_TRUE(own) << own.error();
  double max_dt = 0.0, max_dw = 0.0;
  for (size_t k = 0; k < problem.frames.size(); ++k) {
    max_dt = std::max(
        max_dt,
        (own->T_kf_map[k].inverse().translation() - ceres->T_kf_map[k].inverse().translation()).norm());
    max_dw = std::max(max_dw, (own->w[k] - ceres->w[k]).norm());
  }
  std::vector<int> both;
  std::set_intersection(own->outliers.begin(), own->outliers.end(), ceres->outliers.begin(),
                        ceres->outliers.end(), std::back_inserter(both));
  const double rms_own = rmsAgainstTruth(s, *own), rms_ceres = rmsAgainstTruth(s, *ceres);
  std::printf(
      "[ measured ] %zu observations: cost %.2f (own, %d iterations, %.0f ms) vs %.2f (Ceres, %d, %.0f ms); "
      "outliers %zu vs %zu (%zu common); poses differ <= %.2e m, w <= %.2e rad; truth rms %.5f vs %.5f m\n",
      problem.observations.size(), own->report.final_cost, own->report.iterations, own->report.time_ms,
      ceres->report.final_cost, ceres->report.iterations, ceres->report.time_ms, own->outliers.size(),
      ceres->outliers.size(), both.size(), max_dt, max_dw, rms_own, rms_ceres);
  EXPECT_NEAR(own->report.final_cost, ceres->report.final_cost, 1e-3 * ceres->report.final_cost);
  EXPECT_NEAR(own->report.initial_cost, ceres->report.initial_cost, 1e-9 * ceres->report.initial_cost)
      << "the two solvers do not evaluate the same cost";
  const size_t n_out = std::max(own->outliers.size(), ceres->outliers.size());
  EXPECT_GT(n_out, problem.observations.size() / 40) << "the wrong observations were not found";
  EXPECT_GE(both.size(), n_out - n_out / 100);
  EXPECT_LT(max_dt, 2e-4);
  EXPECT_LT(max_dw, 1e-3);
  EXPECT_LT(rms_own, 0.002);
  EXPECT_LT(rms_ceres, 0.002);
}

// Relative-pose priors (pose-graph edges the landmarks do not cover) enter both solvers alike.
// Here priors between consecutive frames, each 3 cm and ~0.6 deg off the truth, pull against the
// observations: both solvers must reach the same minimum, and it must differ from the one without priors.
TEST(SchurSolver, PosePriorsReachTheMinimumCeresReaches) {
  BaSynthConfig o;
  o.keyframes = 8;
  const BaSynthScene s = makeBaSynthScene(o);
  BaProblem problem = syntheticProblem(s, 0.0, 6);
  const BaProblem without = problem;
  for (int k = 0; k + 1 < o.keyframes; ++k) {
    const SE3 truth = s.T_map_kf[k].inverse() * s.T_map_kf[k + 1];
    const SE3 off = se3::exp((Vec6() << 0.03, -0.02, 0.01, 0.01, 0.0, -0.005).finished());
    problem.priors.push_back({k, k + 1, truth * off, Mat6::Identity() * 200.0});  // sigma 5 mm, 0.3 deg
  }
  BaSolveConfig config;
  config.first_iterations = 20;
  config.second_iterations = 30;
  config.max_time_s = 60.0;
  config.rolling_shutter = false;
  config.solver = BaSolver::kCeres;
  const Result<BaSolution> ceres = solveBundle(problem, config);
  config.solver = BaSolver::kSchur;
  const Result<BaSolution> own = solveBundle(problem, config);
  const Result<BaSolution> free = solveBundle(without, config);
  ASSERT_TRUE(ceres && own && free);
  double max_dt = 0.0, moved = 0.0;
  for (size_t k = 0; k < problem.frames.size(); ++k) {
    const Vec3 c_own = own->T_kf_map[k].inverse().translation();
    max_dt = std::max(max_dt, (c_own - ceres->T_kf_map[k].inverse().translation()).norm());
    moved = std::max(moved, (c_own - free->T_kf_map[k].inverse().translation()).norm());
  }
  std::printf(
      "[ measured ] with priors: cost %.3f (own, %d iterations, %zu outliers) vs %.3f (Ceres, %d, %zu), "
      "poses "
      "differ <= %.2e m; the priors moved poses by up to %.2e m\n",
      own->report.final_cost, own->report.iterations, own->outliers.size(), ceres->report.final_cost,
      ceres->report.iterations, ceres->outliers.size(), max_dt, moved);
  EXPECT_NEAR(own->report.initial_cost, ceres->report.initial_cost, 1e-9 * ceres->report.initial_cost)
      << "the two solvers do not evaluate the same cost";
  EXPECT_NEAR(own->report.final_cost, ceres->report.final_cost, 1e-3 * ceres->report.final_cost);
  EXPECT_LT(max_dt, 2e-4);
  EXPECT_GT(moved, 1e-3) << "the priors changed nothing";
  BaProblem bad = problem;
  bad.priors[0].frame_b = 99;
  EXPECT_FALSE(solveBundle(bad, config)) << "a prior out of range was accepted";
}

// A large reduced camera system is solved by conjugate gradients on the implicit Schur
// complement (BaSolveConfig::iterative_min_frames) instead of a sparse Cholesky. Forced onto a problem of
// 70 keyframes (630 unknowns: past the dense factorisation) with wrong observations and relative-pose
// priors, it must reach the minimum the Cholesky reaches; with one CG step per iteration it must not (the
// setting is in use).
TEST(SchurSolver, ConjugateGradientsOnTheImplicitSchurComplementReachTheCholeskyMinimum) {
  BaSynthConfig o;
  o.keyframes = 70;
  o.points = 700;
  o.rolling_shutter_rad = 0.01;
  const BaSynthScene s = makeBaSynthScene(o);
  BaProblem problem = syntheticProblem(s, 0.05, 8);
  for (int k = 0; k + 1 < o.keyframes; k += 7) {
    const SE3 truth = s.T_map_kf[k].inverse() * s.T_map_kf[k + 1];
    const SE3 off = se3::exp((Vec6() << 0.01, -0.01, 0.005, 0.003, 0.0, -0.002).finished());
    problem.priors.push_back({k, k + 1, truth * off, Mat6::Identity() * 100.0});
  }
  BaSolveConfig config;
  config.first_iterations = 20;
  config.second_iterations = 30;
  config.max_time_s = 60.0;
  const Result<BaSolution> cholesky = solveBundle(problem, config);
  config.iterative_min_frames = 1;
  config.iterative_tolerance = 1e-8;
  config.iterative_max_steps = 2000;
  const Result<BaSolution> cg = solveBundle(problem, config);
  config.iterative_max_steps = 1;
  const Result<BaSolution> cut = solveBundle(problem, config);
  ASSERT_TRUE(cholesky && cg && cut);
  double max_dt = 0.0, max_dw = 0.0;
  for (size_t k = 0; k < problem.frames.size(); ++k) {
    max_dt = std::max(
        max_dt,
        (cg->T_kf_map[k].inverse().translation() - cholesky->T_kf_map[k].inverse().translation()).norm());
    max_dw = std::max(max_dw, (cg->w[k] - cholesky->w[k]).norm());
  }
  std::printf(
      "[ measured ] %zu observations: cost %.3f (CG, %d iterations, %.0f ms) vs %.3f (Cholesky, %d, %.0f "
      "ms), "
      "%.3f with one CG step; outliers %zu vs %zu; poses differ <= %.2e m, w <= %.2e rad; truth rms %.5f vs "
      "%.5f m\n",
      problem.observations.size(), cg->report.final_cost, cg->report.iterations, cg->report.time_ms,
      cholesky->report.final_cost, cholesky->report.iterations, cholesky->report.time_ms,
      cut->report.final_cost, cg->outliers.size(), cholesky->outliers.size(), max_dt, max_dw,
      rmsAgainstTruth(s, *cg), rmsAgainstTruth(s, *cholesky));
  EXPECT_NEAR(cg->report.initial_cost, cholesky->report.initial_cost, 1e-9 * cholesky->report.initial_cost);
  EXPECT_NEAR(cg->report.final_cost, cholesky->report.final_cost, 1e-3 * cholesky->report.final_cost);
  EXPECT_LT(max_dt, 2e-4);
  EXPECT_LT(max_dw, 1e-3);
  EXPECT_EQ(cg->outliers, cholesky->outliers);
  EXPECT_GT(cut->report.final_cost, 1.1 * cholesky->report.final_cost)
      << "one conjugate-gradient step per iteration reached the minimum: is the iterative solver in use?";
}

TEST(SchurSolver, HeldFramesStayAndACancelledSolveReturnsItsBestEstimate) {
  BaSynthConfig o;
  o.keyframes = 8;
  const BaSynthScene s = makeBaSynthScene(o);
  BaProblem problem = syntheticProblem(s, 0.0, 4);
  problem.frames[3].fixed = problem.frames[3].fixed_w = true;
  const Result<BaSolution> x = solveBundle(problem, BaSolveConfig{});
  ASSERT_TRUE(x) << x.error();
  EXPECT_TRUE(x->T_kf_map[0].isApprox(problem.frames[0].T_kf_map, 1e-12));
  EXPECT_TRUE(x->T_kf_map[3].isApprox(problem.frames[3].T_kf_map, 1e-12));
  EXPECT_EQ(x->w[3], problem.frames[3].w);
  // Frame 3 is held where it was perturbed to, so the others cannot fit it exactly.
  EXPECT_LT(x->report.final_cost, 0.1 * x->report.initial_cost);
  std::atomic<bool> cancel{true};
  const Result<BaSolution> c = solveBundle(problem, BaSolveConfig{}, &cancel);
  ASSERT_TRUE(c) << c.error();
  EXPECT_TRUE(c->report.cancelled);
  EXPECT_EQ(c->report.iterations, 0);
  EXPECT_TRUE(c->T_kf_map[5].isApprox(problem.frames[5].T_kf_map, 1e-12)) << "a cancelled solve moved";
}

/// Eight keyframes, 5 % wrong observations: the time-limit and iteration-cap tests' problem.
BaProblem eightKeyframeProblem() {
  BaSynthConfig o;
  o.keyframes = 8;
  return syntheticProblem(makeBaSynthScene(o), 0.05, 5);
}

TEST(SchurSolver, ASolveOutOfTimeRejectsNoObservation) {
  const BaProblem problem = eightKeyframeProblem();
  for (BaSolver solver : {BaSolver::kSchur, BaSolver::kCeres}) {
    BaSolveConfig config;
    config.solver = solver;
    const Result<BaSolution> full = solveBundle(problem, config);
    ASSERT_TRUE(full) << full.error();
    EXPECT_FALSE(full->report.out_of_time);
    EXPECT_GT(full->outliers.size(), problem.observations.size() / 40);
    config.max_time_s = 1e-9;  // out of time before the first step
    const Result<BaSolution> cut = solveBundle(problem, config);
    ASSERT_TRUE(cut) << cut.error();
    EXPECT_TRUE(cut->report.out_of_time);
    EXPECT_TRUE(cut->outliers.empty()) << "an unconverged solve rejected observations";
  }
}

// Without a time limit (the default) a solve ends at convergence or at its iteration cap, and says which:
// the global-BA schedule backs off after capped adjustments that gain nothing.
TEST(SchurSolver, TheDefaultHasNoTimeLimitAndReportsTheIterationCap) {
  const BaProblem problem = eightKeyframeProblem();
  for (BaSolver solver : {BaSolver::kSchur, BaSolver::kCeres}) {
    BaSolveConfig config;
    config.solver = solver;
    EXPECT_EQ(config.max_time_s, 0.0) << "a wall-clock limit makes the map depend on the machine's load";
    config.first_iterations = 20;
    config.second_iterations = 50;
    const Result<BaSolution> converged = solveBundle(problem, config);
    ASSERT_TRUE(converged) << converged.error();
    EXPECT_FALSE(converged->report.out_of_time);
    EXPECT_FALSE(converged->report.at_iteration_cap) << converged->report.iterations << " iterations";
    config.second_iterations = 1;
    const Result<BaSolution> capped = solveBundle(problem, config);
    ASSERT_TRUE(capped) << capped.error();
    EXPECT_TRUE(capped->report.at_iteration_cap);
    EXPECT_FALSE(capped->report.out_of_time);
  }
}

}  // namespace
}  // namespace rgbdmap
