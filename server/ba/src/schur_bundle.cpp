#include "schur_bundle.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <utility>

#include "iterative_schur.hpp"
#include "point_elimination.hpp"
#include "reduced_camera_system.hpp"
#include "schur_evaluator.hpp"
#include "schur_step.hpp"
#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {
namespace {

// Ceres' defaults for Levenberg-Marquardt (Solver::Options), so that both solvers stop alike.
constexpr double kInitialRadius = 1e4, kMaxRadius = 1e16, kMinRadius = 1e-32;
constexpr double kMinRelativeDecrease = 1e-3, kFunctionTolerance = 1e-6, kParameterTolerance = 1e-8;
/// Reduced camera systems up to this many unknowns are factorised densely (a local window), larger ones
/// with a sparse Cholesky.
constexpr int kDenseMaxUnknowns = 600;

/// Levenberg-Marquardt with Ceres' trust-region rule over the frames and points of a SchurStructure; the
/// damped step's frame part comes from a SchurStep, its point part from the back-substitution.
template <int D>
class LevenbergMarquardt {
 public:
  using VecD = Eigen::Matrix<double, D, 1>;
  LevenbergMarquardt(const SchurStructure& s, const SchurEvaluator<D>& cost, SchurStep<D>* linear,
                     std::vector<FrameState> frames, std::vector<Vec3> points)
      : s_(s),
        cost_(cost),
        linear_(linear),
        lin_(s),
        elimination_(s),
        dx_frame_(s.nv * D),
        frames_(std::move(frames)),
        points_(std::move(points)) {}
  /// Runs up to `iterations` steps from the current state, or until the time limit (from t0) or a cancel.
  void run(int iterations, const BaSolveConfig& c, std::chrono::steady_clock::time_point t0,
           const std::atomic<bool>* cancel, SolveSummary* summary);
  const std::vector<FrameState>& frames() const { return frames_; }
  const std::vector<Vec3>& points() const { return points_; }

 private:
  bool step(double lambda, double* model_decrease);
  bool negligibleStep() const;
  void applyStep();

  const SchurStructure& s_;
  const SchurEvaluator<D>& cost_;
  SchurStep<D>* linear_;
  Linearisation<D> lin_;
  PointElimination<D> elimination_;
  Eigen::VectorXd dx_frame_;
  std::vector<FrameState> frames_;
  std::vector<Vec3> points_;
};

// The damped step (landmarks eliminated, reduced system solved, landmarks back-substituted) and the
// decrease the linear model predicts for it; false when a system is not positive definite.
template <int D>
bool LevenbergMarquardt<D>::step(double lambda, double* model_decrease) {
  if (!linear_->solve(lin_, lambda, &elimination_, &dx_frame_)) return false;
  if (!dx_frame_.allFinite()) return false;
  // Predicted decrease 0.5 * dx' (lambda D dx - g), over every unknown.
  double predicted = 0.0;
  for (int a = 0; a < s_.nv; ++a) {
    const VecD d = dx_frame_.segment<D>(a * D);
    predicted += d.dot(lambda * dampingOf<D>(lin_.U[a]).cwiseProduct(d) - lin_.g_frame[a]);
  }
  elimination_.backSubstitute(s_, lin_, dx_frame_, lambda, &predicted);
  *model_decrease = 0.5 * predicted;
  return true;
}

/// Converged in the parameters: the step is negligible against the state.
template <int D>
bool LevenbergMarquardt<D>::negligibleStep() const {
  double x_norm2 = 0.0, dx_norm2 = dx_frame_.squaredNorm();
  for (int f = 0; f < s_.nf; ++f) x_norm2 += frames_[f].t.squaredNorm() + frames_[f].w.squaredNorm() + 1.0;
  for (int j = 0; j < s_.npv; ++j) {
    x_norm2 += points_[s_.var_point[j]].squaredNorm();
    dx_norm2 += elimination_.dx_point[j].squaredNorm();
  }
  return std::sqrt(dx_norm2) <= kParameterTolerance * (std::sqrt(x_norm2) + kParameterTolerance);
}

template <int D>
void LevenbergMarquardt<D>::applyStep() {
  for (int a = 0; a < s_.nv; ++a) {
    FrameState& F = frames_[s_.var_frame[a]];
    const VecD d = dx_frame_.segment<D>(a * D);
    if (s_.pose_free[s_.var_frame[a]]) {
      const SE3 E = se3::exp(d.template head<6>());
      F.t = E.linear() * F.t + E.translation();
      F.R = E.linear() * F.R;
    }
    if constexpr (D == 9)
      if (s_.w_var[s_.var_frame[a]]) F.w += d.template tail<3>();
  }
  for (int j = 0; j < s_.npv; ++j) points_[s_.var_point[j]] += elimination_.dx_point[j];
}

template <int D>
void LevenbergMarquardt<D>::run(int iterations, const BaSolveConfig& c, std::chrono::steady_clock::time_point t0,
                                const std::atomic<bool>* cancel, SolveSummary* summary) {
  double cost = cost_.evaluate(frames_, points_, &lin_);
  summary->initial_cost = cost;
  double radius = kInitialRadius, decrease_factor = 2.0;
  std::vector<FrameState> frames_before;
  std::vector<Vec3> points_before;
  for (int it = 0; it < iterations && std::isfinite(cost); ++it) {
    if (cancel && cancel->load()) break;
    if (pastTimeLimit(c, t0)) {
      summary->out_of_time = true;
      break;
    }
    ++summary->iterations;
    double predicted = 0.0;
    if (!step(1.0 / radius, &predicted) || !(predicted > 0.0)) {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) break;
      continue;
    }
    if (negligibleStep()) break;
    frames_before = frames_;
    points_before = points_;
    applyStep();
    const double new_cost = cost_.evaluate(frames_, points_, nullptr);
    const double relative = (cost - new_cost) / predicted;
    if (std::isfinite(new_cost) && relative > kMinRelativeDecrease) {
      const bool converged = cost - new_cost <= kFunctionTolerance * cost;
      cost = new_cost;
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * relative - 1.0, 3)));
      decrease_factor = 2.0;
      if (converged) break;
      cost_.evaluate(frames_, points_, &lin_);
    } else {
      frames_ = std::move(frames_before);
      points_ = std::move(points_before);
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      if (radius < kMinRadius) break;
    }
  }
  summary->final_cost = cost;
}

}  // namespace

BaMeasurement measurementOf(const BaObservation& o, double sigma, const BaSolveConfig& c) {
  return {o.px, sigma, o.row_fraction, c.use_depth ? o.depth_m : 0.0, c.inverse_depth_sigma};
}

SolveSummary SchurBundle::solve(int iterations, const std::atomic<bool>* cancel) {
  // A frame has 9 unknowns only while some rolling-shutter rotation is estimated.
  bool any_w = false;
  if (w_free_ && c_.rolling_shutter)
    for (const BaFrame& f : p_.frames) any_w = any_w || !f.fixed_w;
  return any_w ? solveWith<9>(iterations, cancel) : solveWith<6>(iterations, cancel);
}

template <int D>
SolveSummary SchurBundle::solveWith(int iterations, const std::atomic<bool>* cancel) {
  const auto t0 = std::chrono::steady_clock::now();
  SolveSummary summary;
  SchurStructure st = buildSchurStructure(p_, c_, s_->active, D == 9 && w_free_);
  if (st.free_poses == 0) return summary;
  const bool dense = st.nv * D <= kDenseMaxUnknowns;
  // A large reduced system (a global BA of a large map) is never formed: conjugate gradients apply it as
  // U - sum_j W_j V_j^-1 W_j^T, point by point (memory linear in the observations).
  const bool iterative = !dense && st.nv >= c_.iterative_min_frames;
  std::unique_ptr<SchurStep<D>> linear;
  if (iterative)
    linear = std::make_unique<IterativeSchur<D>>(st, c_, t0, cancel, &summary.linear_steps);
  else
    linear = std::make_unique<ReducedCameraSystem<D>>(&st, dense);
  std::vector<FrameState> frames(st.nf);
  for (int f = 0; f < st.nf; ++f) {
    const SE3 T = paramsToPose(s_->poses[f].data());
    frames[f] = {T.linear(), T.translation(), s_->w[f]};
  }
  const SchurEvaluator<D> cost(p_, c_, s_->sigma_px, st);
  LevenbergMarquardt<D> lm(st, cost, linear.get(), std::move(frames), s_->points);
  lm.run(iterations, c_, t0, cancel, &summary);
  for (int f = 0; f < st.nf; ++f) {
    if (st.frame_var[f] < 0) continue;
    SE3 T = SE3::Identity();
    T.linear() = lm.frames()[f].R;
    T.translation() = lm.frames()[f].t;
    poseToParams(T, s_->poses[f].data());
    s_->w[f] = lm.frames()[f].w;
  }
  for (int j = 0; j < st.npv; ++j) s_->points[st.var_point[j]] = lm.points()[st.var_point[j]];
  return summary;
}

template SolveSummary SchurBundle::solveWith<6>(int, const std::atomic<bool>*);
template SolveSummary SchurBundle::solveWith<9>(int, const std::atomic<bool>*);

}  // namespace rgbdmap::ba_detail
