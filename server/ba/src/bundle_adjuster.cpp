#include "rgbdmap/ba/bundle_adjuster.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>

#include <ceres/ceres.h>

#include "schur_bundle.hpp"

namespace rgbdmap {
namespace {

using ba_detail::measurementOf;
using ba_detail::SolveState;
using ba_detail::SolveSummary;

class CancelCallback final : public ceres::IterationCallback {
 public:
  explicit CancelCallback(const std::atomic<bool>* cancel) : cancel_(cancel) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return cancel_ && cancel_->load() ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
  }

 private:
  const std::atomic<bool>* cancel_;
};

std::string checkProblem(const BaProblem& p) {
  if (p.frames.empty() || p.points.empty() || p.observations.empty()) return "empty problem";
  bool any_free = false;
  for (const BaFrame& f : p.frames) {
    if (!se3::isValid(f.T_kf_map, 1e-4) || !f.w.allFinite())
      return "frame " + std::to_string(f.id) + ": invalid pose";
    any_free = any_free || !f.fixed;
  }
  if (!any_free) return "every frame is fixed";
  for (const BaPoint& q : p.points)
    if (!q.p_map.allFinite()) return "point " + std::to_string(q.id) + ": not finite";
  const int nf = static_cast<int>(p.frames.size()), np = static_cast<int>(p.points.size());
  for (const BaObservation& o : p.observations) {
    if (o.frame < 0 || o.frame >= nf || o.point < 0 || o.point >= np) return "observation out of range";
    if (!o.px.allFinite() || !std::isfinite(o.depth_m) || o.depth_m < 0.0 || o.octave < 0 || o.octave > 31 ||
        !(std::abs(o.row_fraction) <= 1.0))
      return "observation not finite or out of range";
  }
  for (const BaPosePrior& q : p.priors)
    if (q.frame_a < 0 || q.frame_a >= nf || q.frame_b < 0 || q.frame_b >= nf || q.frame_a == q.frame_b ||
        !se3::isValid(q.T_a_b, 1e-4) || !q.sqrt_information.allFinite())
      return "pose prior out of range or not finite";
  return "";
}

/// A pose prior for Ceres: the same residual. As the observation costs do, it gives its Jacobians in the
/// tangent of BaPoseManifold (the left perturbation exp(d) * T_kf_map) in the first 6 of the 7 columns (the
/// manifold's PlusJacobian is that selection); here by central differences (a few priors per adjustment).
class PosePriorCost final : public ceres::SizedCostFunction<6, 7, 7> {
 public:
  explicit PosePriorCost(const BaPosePrior& prior) : prior_(prior) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const SE3 Ta = paramsToPose(parameters[0]), Tb = paramsToPose(parameters[1]);
    Eigen::Map<Vec6> r(residuals);
    r = posePriorResidual(prior_, Ta, Tb);
    if (!jacobians) return r.allFinite();
    constexpr double kStep = 1e-6;
    for (int side = 0; side < 2; ++side) {
      if (!jacobians[side]) continue;
      Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobians[side]);
      J.setZero();
      for (int i = 0; i < 6; ++i) {
        const Vec6 d = Vec6::Unit(i) * kStep;
        const Vec6 plus = side == 0 ? posePriorResidual(prior_, se3::exp(d) * Ta, Tb)
                                    : posePriorResidual(prior_, Ta, se3::exp(d) * Tb);
        const Vec6 minus = side == 0 ? posePriorResidual(prior_, se3::exp(-d) * Ta, Tb)
                                     : posePriorResidual(prior_, Ta, se3::exp(-d) * Tb);
        J.col(i) = (plus - minus) / (2.0 * kStep);
      }
    }
    return r.allFinite();
  }

 private:
  BaPosePrior prior_;
};

double sigmaOf(const BaObservation& o, const BaSolveConfig& c) {
  return c.pixel_sigma * std::pow(c.scale_factor, o.octave);
}

ceres::CostFunction* costOf(const BaProblem& p, const BaObservation& o, double sigma,
                            const BaSolveConfig& c) {
  const BaIntrinsics& k = p.frames[o.frame].camera;
  const BaMeasurement m = measurementOf(o, sigma, c);
  if (m.depth_m > 0.0) return new ReprojectionDepthCost(k, m);
  return new ReprojectionCost(k, m);
}

/// The Ceres problem of one adjustment, built once: a residual block per active observation (Huber at the
/// chi2 thresholds: after the outliers leave, every remaining residual is below them, so the second solve
/// is plain least squares as in ORB-SLAM), landmarks eliminated first (Schur complement).
class CeresBundle {
 public:
  CeresBundle(const BaProblem& p, const BaSolveConfig& c, SolveState* s)
      : p_(p),
        c_(c),
        s_(s),
        problem_(problemOptions()),
        huber2_(std::sqrt(c.chi2_2dof)),
        huber3_(std::sqrt(c.chi2_3dof)),
        blocks_(p.observations.size(), nullptr),
        point_residuals_(p.points.size(), 0) {
    std::vector<char> pose_added(p.frames.size(), 0);
    for (size_t i = 0; i < p.observations.size(); ++i) {
      if (!s->active[i]) continue;
      const BaObservation& o = p.observations[i];
      const bool depth = c.use_depth && o.depth_m > 0.0;
      double* pose = s->poses[o.frame].data();
      double* point = s->points[o.point].data();
      double* w = s->w[o.frame].data();
      blocks_[i] = problem_.AddResidualBlock(costOf(p, o, s->sigma_px[i], c),
                                             depth ? static_cast<ceres::LossFunction*>(&huber3_) : &huber2_,
                                             pose, point, w);
      ++point_residuals_[o.point];
      if (pose_added[o.frame]) continue;
      pose_added[o.frame] = 1;
      problem_.SetManifold(pose, &manifold_);
      frame_blocks_.push_back(pose);
      frame_blocks_.push_back(w);
      const bool fixed = p.frames[o.frame].fixed;
      if (fixed) problem_.SetParameterBlockConstant(pose);
      // w is held in the first (robust) solve: with wrong matches still in, its freedom would fit them.
      problem_.SetParameterBlockConstant(w);
      if (!p.frames[o.frame].fixed_w && c.rolling_shutter) {
        problem_.AddResidualBlock(
            new RollingShutterPrior(c.rolling_shutter_sigma_rad, p.frames[o.frame].w_prior), nullptr, w);
        rolling_shutter_.push_back(w);
      }
      free_frames_ += fixed ? 0 : 1;
    }
    for (const BaPosePrior& q : p.priors) {
      if (!pose_added[q.frame_a] || !pose_added[q.frame_b]) continue;
      problem_.AddResidualBlock(new PosePriorCost(q), nullptr, s->poses[q.frame_a].data(),
                                s->poses[q.frame_b].data());
    }
  }

  /// Levenberg-Marquardt from the current parameters; nothing when no frame is free.
  SolveSummary solve(int iterations, const std::atomic<bool>* cancel) {
    if (free_frames_ == 0) return {};
    ceres::Solver::Options so;
    so.linear_solver_type = free_frames_ <= 40 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    // A fresh ordering each solve (Ceres drops the blocks that were constant from the one it is given):
    // landmarks eliminated first.
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t i = 0; i < p_.points.size(); ++i)
      if (point_residuals_[i] > 0) ordering->AddElementToGroup(s_->points[i].data(), 0);
    for (double* block : frame_blocks_) ordering->AddElementToGroup(block, 1);
    so.linear_solver_ordering = ordering;
    so.max_num_iterations = iterations;
    if (c_.max_time_s > 0.0) so.max_solver_time_in_seconds = c_.max_time_s;
    so.num_threads = c_.num_threads;
    so.logging_type = ceres::SILENT;
    so.minimizer_progress_to_stdout = false;
    CancelCallback cancel_callback(cancel);
    if (cancel) so.callbacks.push_back(&cancel_callback);
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem_, &summary);
    return {
        summary.initial_cost, summary.final_cost, static_cast<int>(summary.iterations.size()),
        c_.max_time_s > 0.0 && summary.termination_type == ceres::NO_CONVERGENCE &&
            summary.total_time_in_seconds >= c_.max_time_s};
  }

  /// The free frames' rolling-shutter rotations take part from now on.
  void freeRollingShutter() {
    for (double* w : rolling_shutter_) problem_.SetParameterBlockVariable(w);
  }

  /// Takes out the observations that classify() made inactive (and landmarks left without any).
  void removeInactive() {
    for (size_t i = 0; i < blocks_.size(); ++i) {
      if (!blocks_[i] || s_->active[i]) continue;
      problem_.RemoveResidualBlock(blocks_[i]);
      blocks_[i] = nullptr;
      const int point = p_.observations[i].point;
      if (--point_residuals_[point] == 0) problem_.RemoveParameterBlock(s_->points[point].data());
    }
  }

 private:
  static ceres::Problem::Options problemOptions() {
    ceres::Problem::Options options;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.enable_fast_removal = true;
    return options;
  }

  const BaProblem& p_;
  const BaSolveConfig& c_;
  SolveState* s_;
  BaPoseManifold manifold_;
  ceres::Problem problem_;
  ceres::HuberLoss huber2_, huber3_;
  std::vector<double*> frame_blocks_;           ///< pose and w of every frame in the problem
  std::vector<ceres::ResidualBlockId> blocks_;  ///< per observation, null when not in the problem
  std::vector<int> point_residuals_;            ///< per point
  std::vector<double*> rolling_shutter_;        ///< w of the free frames (held in the first solve)
  int free_frames_ = 0;
};

/// Marks observations that are behind their camera or above the chi2 threshold inactive; returns the rms
/// reprojection error (octave-0 pixels) of those that stay.
double classify(const BaProblem& p, const BaSolveConfig& c, SolveState* s) {
  double sum_sq = 0.0;
  int n = 0;
  for (size_t i = 0; i < p.observations.size(); ++i) {
    if (!s->active[i]) continue;
    const BaObservation& o = p.observations[i];
    const ObservationResidual r =
        observationResidual(p.frames[o.frame].camera, paramsToPose(s->poses[o.frame].data()),
                            s->points[o.point], s->w[o.frame], measurementOf(o, s->sigma_px[i], c));
    const double limit = r.rows == 3 ? c.chi2_3dof : c.chi2_2dof;
    s->active[i] = r.in_front && r.chi2 <= limit;
    if (!s->active[i]) continue;
    sum_sq += r.reprojection_px.squaredNorm();
    ++n;
  }
  return n ? std::sqrt(sum_sq / n) : 0.0;
}

/// The two solves with the outlier test between them.
template <typename Bundle>
void runSolves(const BaProblem& problem, const BaSolveConfig& config, const std::atomic<bool>* cancel,
               Bundle* bundle, SolveState* s, BaReport* report) {
  const SolveSummary first = bundle->solve(config.first_iterations, cancel);
  report->initial_cost = first.initial_cost;
  report->final_cost = first.final_cost;
  report->iterations = first.iterations;
  report->linear_steps = first.linear_steps;
  report->out_of_time = first.out_of_time;
  report->at_iteration_cap = first.iterations >= config.first_iterations;
  if (first.out_of_time) {
    // Unconverged, residuals are still large where the solve did not get to: the outlier test would take
    // good observations out. The estimate so far (lower cost than the start) stands; no observation leaves.
    SolveState probe = *s;
    report->final_rms_px = classify(problem, config, &probe);
    return;
  }
  report->final_rms_px = classify(problem, config, s);
  const bool cancelled = cancel && cancel->load();
  if (config.second_iterations > 0 && !cancelled) {
    bundle->removeInactive();
    bundle->freeRollingShutter();
    const SolveSummary second = bundle->solve(config.second_iterations, cancel);
    report->final_cost = second.final_cost;
    report->iterations += second.iterations;
    report->linear_steps += second.linear_steps;
    report->out_of_time = second.out_of_time;
    report->at_iteration_cap = second.iterations >= config.second_iterations;
    report->final_rms_px = classify(problem, config, s);
  }
}

}  // namespace

Vec6 posePriorResidual(const BaPosePrior& prior, const SE3& T_a_map, const SE3& T_b_map) {
  return prior.sqrt_information * se3::log(prior.T_a_b.inverse() * T_a_map * T_b_map.inverse());
}

Result<BaSolution> solveBundle(const BaProblem& problem, const BaSolveConfig& config,
                               const std::atomic<bool>* cancel) {
  if (std::string why = checkProblem(problem); !why.empty()) return Result<BaSolution>::failure(why);
  const auto t0 = std::chrono::steady_clock::now();
  SolveState s;
  for (const BaFrame& f : problem.frames) {
    poseToParams(f.T_kf_map, s.poses.emplace_back().data());
    s.w.push_back(f.w);
  }
  for (const BaPoint& q : problem.points) s.points.push_back(q.p_map);
  for (const BaObservation& o : problem.observations) s.sigma_px.push_back(sigmaOf(o, config));
  s.active.assign(problem.observations.size(), 1);
  // Observations behind their camera at the start cannot be evaluated: they are outliers from the outset.
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    const BaObservation& o = problem.observations[i];
    s.active[i] = (problem.frames[o.frame].T_kf_map * problem.points[o.point].p_map).z() > 1e-3;
  }
  BaSolution out;
  BaReport& report = out.report;
  SolveState probe = s;
  report.initial_rms_px = classify(problem, config, &probe);
  if (config.solver == BaSolver::kCeres) {
    CeresBundle bundle(problem, config, &s);
    runSolves(problem, config, cancel, &bundle, &s, &report);
  } else {
    ba_detail::SchurBundle bundle(problem, config, &s);
    runSolves(problem, config, cancel, &bundle, &s, &report);
  }
  report.cancelled = cancel && cancel->load();
  for (size_t i = 0; i < problem.observations.size(); ++i)
    if (!s.active[i]) out.outliers.push_back(static_cast<int>(i));
  for (size_t i = 0; i < problem.frames.size(); ++i) {
    out.T_kf_map.push_back(problem.frames[i].fixed ? problem.frames[i].T_kf_map
                                                   : paramsToPose(s.poses[i].data()));
    out.w.push_back(problem.frames[i].fixed_w ? problem.frames[i].w : s.w[i]);
    report.fixed_frames += problem.frames[i].fixed ? 1 : 0;
  }
  out.p_map = std::move(s.points);
  report.frames = static_cast<int>(problem.frames.size());
  report.points = static_cast<int>(problem.points.size());
  report.observations = static_cast<int>(problem.observations.size());
  report.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace rgbdmap
