#pragma once
// The reduced camera system never formed: S v = (U + lambda D_U) v + priors' cross terms - sum_j W_j V_j^-1
// W_j^T v, applied point by point (memory linear in the observations), as Ceres' ImplicitSchurComplement.
#include <Eigen/Core>

#include "point_elimination.hpp"
#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {

template <int D>
class ImplicitSchurComplement {
 public:
  using MatD = Eigen::Matrix<double, D, D>;
  explicit ImplicitSchurComplement(const SchurStructure& s) : s_(s), damped_(s.nv) {}
  /// U + lambda D per frame unknown; the diagonal blocks of S before the points' terms.
  void setDamping(const Linearisation<D>& lin, double lambda);
  const MatD& damped(int a) const { return damped_[a]; }
  /// out = S v at the damping set last, with the points' V_inv in `points`.
  void apply(const Linearisation<D>& lin, const PointElimination<D>& points, const Eigen::VectorXd& v,
             Eigen::VectorXd* out) const;

 private:
  const SchurStructure& s_;
  AlignedVector<MatD> damped_;
};

}  // namespace rgbdmap::ba_detail
