#pragma once
// The reduced camera system of a large problem, factorised with a sparse Cholesky (simplicial LLT, AMD
// ordering): the pattern of its lower blocks is analysed once per solve, each step only writes the values.
#include <utility>
#include <vector>

#include <Eigen/SparseCholesky>

#include "schur_structure.hpp"

namespace rgbdmap::ba_detail {

template <int D>
class SparseCholesky {
 public:
  using MatD = Eigen::Matrix<double, D, D>;
  /// The pattern of the lower blocks `blocks` ((row, column) block indices; (a, a) keeps its lower
  /// triangle) of an n x n system.
  SparseCholesky(const std::vector<std::pair<int, int>>& blocks, int n);
  /// dx = S^-1 rhs for S with `values[k]` at `blocks[k]`; false when S is not positive definite.
  bool solve(const std::vector<std::pair<int, int>>& blocks, const AlignedVector<MatD>& values,
             const Eigen::VectorXd& rhs, Eigen::VectorXd* dx);

 private:
  Eigen::SparseMatrix<double> S_sparse_;
  std::vector<int> column_offset_;  ///< per block and column: index of its first stored value
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> llt_;
};

}  // namespace rgbdmap::ba_detail
