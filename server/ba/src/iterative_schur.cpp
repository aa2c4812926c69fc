#include "iterative_schur.hpp"

namespace rgbdmap::ba_detail {

template <int D>
IterativeSchur<D>::IterativeSchur(const SchurStructure& s, const BaSolveConfig& c,
                                  std::chrono::steady_clock::time_point t0, const std::atomic<bool>* cancel,
                                  int* linear_steps)
    : s_(s), c_(c), t0_(t0), cancel_(cancel), linear_steps_(linear_steps), S_(s), P_(s), rhs_(s.nv * D) {}

template <int D>
bool IterativeSchur<D>::solve(const Linearisation<D>& lin, double lambda, PointElimination<D>* points,
                              Eigen::VectorXd* dx_frame) {
  S_.setDamping(lin, lambda);
  for (int a = 0; a < s_.nv; ++a) {
    P_.setDiagonal(a, S_.damped(a));  // the diagonal block of S first, inverted below
    rhs_.segment<D>(a * D) = -lin.g_frame[a];
  }
  for (int j = 0; j < s_.npv; ++j) {
    if (!points->eliminate(s_, lin, j, lambda, &rhs_)) return false;
    P_.subtractPoint(lin, *points, j);
  }
  if (!P_.invert()) return false;
  return conjugateGradients(lin, *points, dx_frame);
}

template <int D>
bool IterativeSchur<D>::conjugateGradients(const Linearisation<D>& lin, const PointElimination<D>& points,
                                           Eigen::VectorXd* dx_frame) {
  dx_frame->setZero();
  r_ = rhs_;
  P_.apply(r_, &z_);
  p_ = z_;
  q_.resize(s_.nv * D);
  double rz = r_.dot(z_);
  const double stop = c_.iterative_tolerance * rhs_.norm();
  for (int k = 0; k < c_.iterative_max_steps && r_.norm() > stop; ++k) {
    if ((cancel_ && cancel_->load()) || pastTimeLimit(c_, t0_)) break;
    S_.apply(lin, points, p_, &q_);
    ++*linear_steps_;
    const double pq = p_.dot(q_);
    if (!(pq > 0.0)) return false;
    const double alpha = rz / pq;
    dx_frame->noalias() += alpha * p_;
    r_.noalias() -= alpha * q_;
    P_.apply(r_, &z_);
    const double rz_next = r_.dot(z_);
    p_ = z_ + (rz_next / rz) * p_;
    rz = rz_next;
  }
  return true;
}

template class IterativeSchur<6>;
template class IterativeSchur<9>;

}  // namespace rgbdmap::ba_detail
