#pragma once
// The bundle adjuster's own Levenberg-Marquardt solver (internal to rgbdmap_ba).
//
// Ceres spends most of a bundle adjustment's time per residual block (evaluation through virtual calls,
// Jacobian preparation, the manifold's 7x6 product, hash sets of parameter blocks), not in linear algebra:
// a local BA of ~10 keyframes took 60-100 ms on fr1_rpy. This solver does the same minimisation with the
// problem's structure written in: fixed-size blocks (a frame has 6 unknowns, or 9 while its rolling-shutter
// rotation is estimated; a landmark 3), the landmarks eliminated per point (3x3 inverses), the reduced
// camera system assembled block-sparse and factorised densely (small windows) or with a sparse Cholesky
// (AMD ordering, the pattern analysed once per solve); from BaSolveConfig::iterative_min_frames frame
// unknowns (a global BA of a large map) it is never formed: preconditioned conjugate gradients apply it
// point by point (implicit Schur complement, block-Jacobi preconditioner, as Ceres' ITERATIVE_SCHUR with
// SCHUR_JACOBI), memory linear in the observations. The residuals, Jacobians, Huber loss, rolling-shutter
// prior and trust-region rule are Ceres' (LM with radius 1e4 at the start, the step accepted at a relative
// decrease above 1e-3, function tolerance 1e-6), so both solvers reach the same minimum; a test holds them
// to it (`ba.solver: ceres` keeps Ceres as the reference).
#include <array>
#include <atomic>
#include <vector>

#include "rgbdmap/ba/bundle_adjuster.hpp"

namespace rgbdmap::ba_detail {

using Params = std::array<double, 7>;  ///< [qx qy qz qw tx ty tz] of T_kf_map

/// What one solve works on: the parameters (updated in place) and which observations take part.
struct SolveState {
  std::vector<Params> poses;
  std::vector<Vec3> w;  ///< per frame
  std::vector<Vec3> points;
  std::vector<double> sigma_px;  ///< per observation
  std::vector<char> active;      ///< per observation
};

BaMeasurement measurementOf(const BaObservation& o, double sigma, const BaSolveConfig& c);

struct SolveSummary {
  double initial_cost = 0.0, final_cost = 0.0;  ///< 0.5 * (robust sum + prior), as Ceres reports it
  int iterations = 0;                           ///< steps tried (accepted or not)
  bool out_of_time = false;                     ///< stopped by the wall-clock limit, not converged
  int linear_steps = 0;                         ///< conjugate-gradient steps (the iterative solve only)
};

/// One adjustment's problem for the own solver: the observations SolveState::active marks take part, the
/// rolling-shutter rotations are held until freeRollingShutter().
class SchurBundle {
 public:
  SchurBundle(const BaProblem& p, const BaSolveConfig& c, SolveState* s) : p_(p), c_(c), s_(s) {}
  /// Levenberg-Marquardt from the current parameters; nothing when no frame pose is free.
  SolveSummary solve(int iterations, const std::atomic<bool>* cancel);
  void freeRollingShutter() { w_free_ = true; }
  /// Nothing to do: each solve takes the observations active at its start.
  void removeInactive() {}

 private:
  template <int D>
  SolveSummary solveWith(int iterations, const std::atomic<bool>* cancel);

  const BaProblem& p_;
  const BaSolveConfig& c_;
  SolveState* s_;
  bool w_free_ = false;
};

}  // namespace rgbdmap::ba_detail
