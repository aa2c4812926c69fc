#include "sparse_cholesky.hpp"

#include <algorithm>

namespace rgbdmap::ba_detail {

template <int D>
SparseCholesky<D>::SparseCholesky(const std::vector<std::pair<int, int>>& blocks, int n) {
  std::vector<Eigen::Triplet<double>> pattern;
  for (const auto& [a, b] : blocks)
    for (int c = 0; c < D; ++c)
      for (int r = a == b ? c : 0; r < D; ++r) pattern.emplace_back(a * D + r, b * D + c, 0.0);
  S_sparse_.resize(n, n);
  S_sparse_.setFromTriplets(pattern.begin(), pattern.end());
  S_sparse_.makeCompressed();
  const int* outer = S_sparse_.outerIndexPtr();
  const int* inner = S_sparse_.innerIndexPtr();
  column_offset_.resize(blocks.size() * D);
  for (size_t k = 0; k < blocks.size(); ++k) {
    const auto [a, b] = blocks[k];
    for (int c = 0; c < D; ++c) {
      const int col = b * D + c, row = a == b ? col : a * D;
      column_offset_[k * D + c] =
          static_cast<int>(std::lower_bound(inner + outer[col], inner + outer[col + 1], row) - inner);
    }
  }
  llt_.analyzePattern(S_sparse_);
}

template <int D>
bool SparseCholesky<D>::solve(const std::vector<std::pair<int, int>>& blocks, const AlignedVector<MatD>& values,
                              const Eigen::VectorXd& rhs, Eigen::VectorXd* dx) {
  double* stored = S_sparse_.valuePtr();
  for (size_t k = 0; k < blocks.size(); ++k) {
    const bool diagonal = blocks[k].first == blocks[k].second;
    for (int c = 0; c < D; ++c) {
      double* v = stored + column_offset_[k * D + c];
      for (int r = diagonal ? c : 0; r < D; ++r) *v++ = values[k](r, c);
    }
  }
  llt_.factorize(S_sparse_);
  if (llt_.info() != Eigen::Success) return false;
  *dx = llt_.solve(rhs);
  return true;
}

template class SparseCholesky<6>;
template class SparseCholesky<9>;

}  // namespace rgbdmap::ba_detail
