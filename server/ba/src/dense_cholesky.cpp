#include "dense_cholesky.hpp"

#include <Eigen/Cholesky>

namespace rgbdmap::ba_detail {

template <int D>
bool DenseCholesky<D>::solve(const std::vector<std::pair<int, int>>& blocks, const AlignedVector<MatD>& values,
                             const Eigen::VectorXd& rhs, Eigen::VectorXd* dx) {
  const Eigen::Index n = rhs.size();
  S_dense_.setZero(n, n);
  for (size_t k = 0; k < blocks.size(); ++k)
    S_dense_.block<D, D>(blocks[k].first * D, blocks[k].second * D) = values[k];
  const Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> llt(S_dense_);
  if (llt.info() != Eigen::Success) return false;
  *dx = llt.solve(rhs);
  return true;
}

template class DenseCholesky<6>;
template class DenseCholesky<9>;

}  // namespace rgbdmap::ba_detail
