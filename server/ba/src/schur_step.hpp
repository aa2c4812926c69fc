#pragma once
// What the Levenberg-Marquardt loop knows of a linear solver: the frames' part of the damped step, with
// the points eliminated into a PointElimination for their back-substitution.
#include <Eigen/Core>

#include "point_elimination.hpp"
#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {

template <int D>
class SchurStep {
 public:
  virtual ~SchurStep() = default;
  /// dx_frame of the reduced camera system S dx = rhs at damping lambda (S = U + lambda D_U - sum_j
  /// W_j V_j^-1 W_j^T, rhs = -g_frame + sum_j W_j V_j^-1 g_j). False when a system is not positive
  /// definite.
  virtual bool solve(const Linearisation<D>& lin, double lambda, PointElimination<D>* points,
                     Eigen::VectorXd* dx_frame) = 0;
};

}  // namespace rgbdmap::ba_detail
