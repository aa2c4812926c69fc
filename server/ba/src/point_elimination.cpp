#include "point_elimination.hpp"

namespace rgbdmap::ba_detail {

template <int D>
bool PointElimination<D>::eliminate(const SchurStructure& s, const Linearisation<D>& lin, int j, double lambda,
                                    Eigen::VectorXd* rhs) {
  Mat3 Vd = lin.V[j];
  Vd.diagonal() += lambda * dampingOf<3>(lin.V[j]);
  bool invertible = false;
  Vd.computeInverseWithCheck(V_inv[j], invertible, 1e-300);
  if (!invertible) return false;
  const int first = s.var_start[j], count = s.var_start[j + 1] - first;
  for (int x = 0; x < count; ++x) {
    Y[x].noalias() = lin.W[s.var_obs[first + x]] * V_inv[j];
    rhs->template segment<D>(s.var_of[first + x] * D).noalias() += Y[x] * lin.g_point[j];
  }
  return true;
}

template <int D>
void PointElimination<D>::backSubstitute(const SchurStructure& s, const Linearisation<D>& lin,
                                         const Eigen::VectorXd& dx_frame, double lambda, double* predicted) {
  for (int j = 0; j < s.npv; ++j) {
    Vec3 b = -lin.g_point[j];
    for (int x = s.var_start[j]; x < s.var_start[j + 1]; ++x)
      b.noalias() -= lin.W[s.var_obs[x]].transpose() * dx_frame.segment<D>(s.var_of[x] * D);
    dx_point[j] = V_inv[j] * b;
    *predicted += dx_point[j].dot(lambda * dampingOf<3>(lin.V[j]).cwiseProduct(dx_point[j]) - lin.g_point[j]);
  }
}

template struct PointElimination<6>;
template struct PointElimination<9>;

}  // namespace rgbdmap::ba_detail
