#pragma once
// The damped step of a large problem by preconditioned conjugate gradients on the implicit Schur
// complement with the block-Jacobi preconditioner (Ceres' ITERATIVE_SCHUR with SCHUR_JACOBI).
#include <atomic>
#include <chrono>

#include "block_jacobi_preconditioner.hpp"
#include "implicit_schur_complement.hpp"
#include "schur_step.hpp"

namespace rgbdmap::ba_detail {

/// Whether a solve started at t0 is past the configuration's wall-clock limit; never when it has none (0).
inline bool pastTimeLimit(const BaSolveConfig& c, std::chrono::steady_clock::time_point t0) {
  return c.max_time_s > 0.0 &&
         std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > c.max_time_s;
}

template <int D>
class IterativeSchur final : public SchurStep<D> {
 public:
  /// Stops early at the solve's time limit (from t0) or a cancel; counts its steps in `linear_steps`.
  IterativeSchur(const SchurStructure& s, const BaSolveConfig& c, std::chrono::steady_clock::time_point t0,
                 const std::atomic<bool>* cancel, int* linear_steps);
  bool solve(const Linearisation<D>& lin, double lambda, PointElimination<D>* points,
             Eigen::VectorXd* dx_frame) override;

 private:
  /// Preconditioned conjugate gradients on S dx = rhs from dx = 0. Its iterates keep dx' (S dx - rhs) = 0,
  /// so the predicted decrease holds for a step it stops early (at its tolerance, step cap, the solve's
  /// time limit or a cancel). False when S is found not positive definite.
  bool conjugateGradients(const Linearisation<D>& lin, const PointElimination<D>& points,
                          Eigen::VectorXd* dx_frame);

  const SchurStructure& s_;
  const BaSolveConfig& c_;
  std::chrono::steady_clock::time_point t0_;
  const std::atomic<bool>* cancel_;
  int* linear_steps_;
  ImplicitSchurComplement<D> S_;
  BlockJacobiPreconditioner<D> P_;
  Eigen::VectorXd rhs_, r_, z_, p_, q_;
};

}  // namespace rgbdmap::ba_detail
