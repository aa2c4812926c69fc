#pragma once
// The reduced camera system of a small window, factorised densely (its lower triangle, LLT).
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {

template <int D>
class DenseCholesky {
 public:
  using MatD = Eigen::Matrix<double, D, D>;
  /// dx = S^-1 rhs for S given by its lower blocks (`blocks[k]` = (row, column) of `values[k]`); false
  /// when S is not positive definite.
  bool solve(const std::vector<std::pair<int, int>>& blocks, const AlignedVector<MatD>& values,
             const Eigen::VectorXd& rhs, Eigen::VectorXd* dx);

 private:
  Eigen::MatrixXd S_dense_;
};

}  // namespace rgbdmap::ba_detail
