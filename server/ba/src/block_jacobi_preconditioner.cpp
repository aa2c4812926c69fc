#include "block_jacobi_preconditioner.hpp"

#include <Eigen/Cholesky>

namespace rgbdmap::ba_detail {

template <int D>
void BlockJacobiPreconditioner<D>::subtractPoint(const Linearisation<D>& lin, const PointElimination<D>& points,
                                                 int j) {
  const int first = s_.var_start[j], count = s_.var_start[j + 1] - first;
  for (int x = 0; x < count; ++x)
    for (int y = 0; y < count; ++y)
      if (s_.var_of[first + y] == s_.var_of[first + x])
        P_inv_[s_.var_of[first + x]].noalias() -= points.Y[x].lazyProduct(lin.W[s_.var_obs[first + y]].transpose());
}

template <int D>
bool BlockJacobiPreconditioner<D>::invert() {
  for (int a = 0; a < s_.nv; ++a) {
    const Eigen::LLT<MatD> llt(P_inv_[a]);
    if (llt.info() != Eigen::Success) return false;
    P_inv_[a] = llt.solve(MatD::Identity());
  }
  return true;
}

template <int D>
void BlockJacobiPreconditioner<D>::apply(const Eigen::VectorXd& r, Eigen::VectorXd* z) const {
  z->resize(s_.nv * D);
  for (int a = 0; a < s_.nv; ++a) z->segment<D>(a * D).noalias() = P_inv_[a] * r.segment<D>(a * D);
}

template class BlockJacobiPreconditioner<6>;
template class BlockJacobiPreconditioner<9>;

}  // namespace rgbdmap::ba_detail
