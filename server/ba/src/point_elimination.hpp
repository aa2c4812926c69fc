#pragma once
// The landmarks' share of the damped step: each point eliminated from the normal equations by its 3x3
// inverse (the Schur complement's terms W V^-1 W^T and its right-hand side), and, once the frames' step is
// known, back-substituted: dx_j = V_j^-1 (-g_j - sum W^T dx_frame).
#include <vector>

#include <Eigen/Core>

#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {

template <int D>
struct PointElimination {
  using MatD3 = Eigen::Matrix<double, D, 3>;
  explicit PointElimination(const SchurStructure& s) : V_inv(s.npv), Y(s.max_track), dx_point(s.npv) {}

  /// Point j eliminated at damping lambda: V_inv[j], Y = W V^-1 for each of its observations by a frame
  /// unknown, and its share of the reduced right-hand side added to `rhs`. False when its damped block
  /// is singular.
  bool eliminate(const SchurStructure& s, const Linearisation<D>& lin, int j, double lambda,
                 Eigen::VectorXd* rhs);
  /// dx_point from the frames' step, and each point's share 2 * (dx' (lambda D dx - g)) of the predicted
  /// decrease added to `predicted`.
  void backSubstitute(const SchurStructure& s, const Linearisation<D>& lin, const Eigen::VectorXd& dx_frame,
                      double lambda, double* predicted);

  std::vector<Mat3> V_inv;  ///< per point unknown, at the last damping
  AlignedVector<MatD3> Y;   ///< W V^-1 of the point last eliminated, per observation by a frame unknown
  std::vector<Vec3> dx_point;
};

}  // namespace rgbdmap::ba_detail
