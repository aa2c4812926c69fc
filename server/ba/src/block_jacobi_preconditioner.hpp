#pragma once
// Ceres' SCHUR_JACOBI preconditioner: the inverse of each diagonal block of the reduced camera system,
// S_aa = U_aa + lambda D - sum_j W_ja V_j^-1 W_ja^T.
#include <Eigen/Core>

#include "point_elimination.hpp"
#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {

template <int D>
class BlockJacobiPreconditioner {
 public:
  using MatD = Eigen::Matrix<double, D, D>;
  explicit BlockJacobiPreconditioner(const SchurStructure& s) : s_(s), P_inv_(s.nv) {}
  /// Block a starts as the damped block U_aa + lambda D.
  void setDiagonal(int a, const MatD& damped) { P_inv_[a] = damped; }
  /// Point j's terms subtracted, with Y = W V^-1 of its elimination in `points`.
  void subtractPoint(const Linearisation<D>& lin, const PointElimination<D>& points, int j);
  /// Each block replaced by its inverse; false when one is not positive definite.
  bool invert();
  /// z = P^-1 r.
  void apply(const Eigen::VectorXd& r, Eigen::VectorXd* z) const;

 private:
  const SchurStructure& s_;
  AlignedVector<MatD> P_inv_;
};

}  // namespace rgbdmap::ba_detail
