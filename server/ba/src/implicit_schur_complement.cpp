#include "implicit_schur_complement.hpp"

#include <algorithm>

namespace rgbdmap::ba_detail {

template <int D>
void ImplicitSchurComplement<D>::setDamping(const Linearisation<D>& lin, double lambda) {
  for (int a = 0; a < s_.nv; ++a) {
    damped_[a] = lin.U[a];
    damped_[a].diagonal() += lambda * dampingOf<D>(lin.U[a]);
  }
}

template <int D>
void ImplicitSchurComplement<D>::apply(const Linearisation<D>& lin, const PointElimination<D>& points,
                                       const Eigen::VectorXd& v, Eigen::VectorXd* out) const {
  for (int a = 0; a < s_.nv; ++a) out->segment<D>(a * D).noalias() = damped_[a] * v.segment<D>(a * D);
  for (size_t k = 0; k < s_.priors.size(); ++k) {
    const PriorTerm& t = s_.priors[k];
    if (t.a < 0 || t.b < 0) continue;
    const int hi = std::max(t.a, t.b), lo = std::min(t.a, t.b);
    out->segment<6>(hi * D).noalias() += lin.prior_cross[k] * v.segment<6>(lo * D);
    out->segment<6>(lo * D).noalias() += lin.prior_cross[k].transpose() * v.segment<6>(hi * D);
  }
  for (int j = 0; j < s_.npv; ++j) {
    Vec3 z = Vec3::Zero();
    for (int x = s_.var_start[j]; x < s_.var_start[j + 1]; ++x)
      z.noalias() += lin.W[s_.var_obs[x]].transpose() * v.segment<D>(s_.var_of[x] * D);
    const Vec3 y = points.V_inv[j] * z;
    for (int x = s_.var_start[j]; x < s_.var_start[j + 1]; ++x)
      out->segment<D>(s_.var_of[x] * D).noalias() -= lin.W[s_.var_obs[x]] * y;
  }
}

template class ImplicitSchurComplement<6>;
template class ImplicitSchurComplement<9>;

}  // namespace rgbdmap::ba_detail
