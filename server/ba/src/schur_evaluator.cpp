#include "schur_evaluator.hpp"

#include <cmath>
#include <limits>

namespace rgbdmap::ba_detail {
namespace {

/// Huber as Ceres' HuberLoss(sqrt(b)) on the squared norm s: the cost rho(s) and its slope rho'(s).
struct Robust {
  double rho, weight;
};
Robust huber(double s, double b) {
  if (s <= b) return {s, 1.0};
  const double r = std::sqrt(b * s);
  return {2.0 * r - b, b / r};
}

/// One observation's residual and, when linearised, its Jacobians (rows past the residual's size zero).
struct ObservationTerms {
  Vec3 r = Vec3::Zero();
  Eigen::Matrix<double, 3, 6> J_pose = Eigen::Matrix<double, 3, 6>::Zero();
  Mat3 J_point = Mat3::Zero(), J_w = Mat3::Zero();
};

bool observationTerms(const BaIntrinsics& k, const BaMeasurement& m, const FrameState& F, const Vec3& point,
                      bool linearise, ObservationTerms* o) {
  if (m.depth_m > 0.0) {
    ObservationJacobians<3> J;
    if (!observationJacobians<3>(k, m, F.R, F.t, point, F.w, o->r.data(), linearise ? &J : nullptr))
      return false;
    if (linearise) {
      o->J_pose = J.pose;
      o->J_point = J.point;
      o->J_w = J.w;
    }
  } else {
    ObservationJacobians<2> J;
    if (!observationJacobians<2>(k, m, F.R, F.t, point, F.w, o->r.data(), linearise ? &J : nullptr))
      return false;
    if (linearise) {
      o->J_pose.topRows<2>() = J.pose;
      o->J_point.topRows<2>() = J.point;
      o->J_w.topRows<2>() = J.w;
    }
  }
  return true;
}

SE3 poseOf(const FrameState& F) {
  SE3 T = SE3::Identity();
  T.linear() = F.R;
  T.translation() = F.t;
  return T;
}

using Mat66 = Eigen::Matrix<double, 6, 6>;

/// A prior's Jacobians for the solver's left perturbation (T <- exp(d) T), by central differences; only
/// those of free poses are computed.
void priorJacobians(const PriorTerm& t, const SE3& Ta, const SE3& Tb, Mat66* Ja, Mat66* Jb) {
  constexpr double kStep = 1e-6;
  for (int i = 0; i < 6; ++i) {
    const Vec6 d = Vec6::Unit(i) * kStep;
    if (t.a >= 0)
      Ja->col(i) = (posePriorResidual(*t.prior, se3::exp(d) * Ta, Tb) -
                    posePriorResidual(*t.prior, se3::exp(-d) * Ta, Tb)) /
                   (2.0 * kStep);
    if (t.b >= 0)
      Jb->col(i) = (posePriorResidual(*t.prior, Ta, se3::exp(d) * Tb) -
                    posePriorResidual(*t.prior, Ta, se3::exp(-d) * Tb)) /
                   (2.0 * kStep);
  }
}

}  // namespace

template <int D>
SchurEvaluator<D>::SchurEvaluator(const BaProblem& p, const BaSolveConfig& c, const std::vector<double>& sigma_px,
                                  const SchurStructure& s)
    : p_(p),
      c_(c),
      sigma_px_(sigma_px),
      s_(s),
      prior_info_(1.0 / (c.rolling_shutter_sigma_rad * c.rolling_shutter_sigma_rad)) {}

template <int D>
double SchurEvaluator<D>::evaluate(const std::vector<FrameState>& frames, const std::vector<Vec3>& points,
                                   Linearisation<D>* lin) const {
  if (lin) {
    for (int a = 0; a < s_.nv; ++a) {
      lin->U[a].setZero();
      lin->g_frame[a].setZero();
    }
    for (int j = 0; j < s_.npv; ++j) {
      lin->V[j].setZero();
      lin->g_point[j].setZero();
    }
  }
  double sum = 0.0;
  if (!addObservations(frames, points, lin, &sum)) return std::numeric_limits<double>::infinity();
  if (!addPosePriors(frames, lin, &sum)) return std::numeric_limits<double>::infinity();
  addRollingShutterPriors(frames, lin, &sum);
  if (lin)  // held parts of a frame unknown: a unit diagonal and no gradient keep their step 0
    for (int a = 0; a < s_.nv; ++a) {
      const int f = s_.var_frame[a];
      if (!s_.pose_free[f]) lin->U[a].template topLeftCorner<6, 6>().diagonal().setOnes();
      if (D == 9 && !s_.w_var[f]) lin->U[a].template bottomRightCorner<3, 3>().diagonal().setOnes();
    }
  return 0.5 * sum;
}

template <int D>
bool SchurEvaluator<D>::addObservations(const std::vector<FrameState>& frames, const std::vector<Vec3>& points,
                                        Linearisation<D>* lin, double* sum) const {
  for (size_t q = 0; q < s_.obs.size(); ++q) {
    const int i = s_.obs[q];
    const BaObservation& o = p_.observations[i];
    const BaMeasurement m = measurementOf(o, sigma_px_[i], c_);
    ObservationTerms T;
    if (!observationTerms(p_.frames[o.frame].camera, m, frames[o.frame], points[o.point], lin != nullptr, &T))
      return false;
    const Robust h = huber(T.r.squaredNorm(), m.depth_m > 0.0 ? c_.chi2_3dof : c_.chi2_2dof);
    *sum += h.rho;
    if (!lin) continue;
    const double sw = std::sqrt(h.weight);
    T.r *= sw;
    T.J_point *= sw;
    const int j = s_.point_var[o.point];
    lin->V[j].noalias() += T.J_point.transpose() * T.J_point;
    lin->g_point[j].noalias() += T.J_point.transpose() * T.r;
    const int a = s_.frame_var[o.frame];
    if (a < 0) continue;
    Eigen::Matrix<double, 3, D> J_frame = Eigen::Matrix<double, 3, D>::Zero();
    if (s_.pose_free[o.frame]) J_frame.template leftCols<6>() = sw * T.J_pose;
    if constexpr (D == 9)
      if (s_.w_var[o.frame]) J_frame.template rightCols<3>() = sw * T.J_w;
    lin->U[a].noalias() += J_frame.transpose().lazyProduct(J_frame);
    lin->g_frame[a].noalias() += J_frame.transpose() * T.r;
    lin->W[q].noalias() = J_frame.transpose() * T.J_point;
  }
  return true;
}

template <int D>
bool SchurEvaluator<D>::addPosePriors(const std::vector<FrameState>& frames, Linearisation<D>* lin,
                                      double* sum) const {
  for (size_t k = 0; k < s_.priors.size(); ++k) {
    const PriorTerm& t = s_.priors[k];
    const SE3 Ta = poseOf(frames[t.prior->frame_a]), Tb = poseOf(frames[t.prior->frame_b]);
    const Vec6 r = posePriorResidual(*t.prior, Ta, Tb);
    if (!r.allFinite()) return false;
    *sum += r.squaredNorm();
    if (!lin) continue;
    Mat66 Ja = Mat66::Zero(), Jb = Mat66::Zero();
    priorJacobians(t, Ta, Tb, &Ja, &Jb);
    if (t.a >= 0) {
      lin->U[t.a].template topLeftCorner<6, 6>().noalias() += Ja.transpose() * Ja;
      lin->g_frame[t.a].template head<6>().noalias() += Ja.transpose() * r;
    }
    if (t.b >= 0) {
      lin->U[t.b].template topLeftCorner<6, 6>().noalias() += Jb.transpose() * Jb;
      lin->g_frame[t.b].template head<6>().noalias() += Jb.transpose() * r;
    }
    if (t.a >= 0 && t.b >= 0) lin->prior_cross[k] = t.a > t.b ? Ja.transpose() * Jb : Jb.transpose() * Ja;
  }
  return true;
}

template <int D>
void SchurEvaluator<D>::addRollingShutterPriors(const std::vector<FrameState>& frames, Linearisation<D>* lin,
                                                double* sum) const {
  for (int f = 0; f < s_.nf; ++f) {
    if (!s_.in_problem[f] || !s_.has_prior[f]) continue;
    const Vec3 dw = frames[f].w - p_.frames[static_cast<size_t>(f)].w_prior;
    *sum += dw.squaredNorm() * prior_info_;
    if (!lin || !s_.w_var[f]) continue;
    const int a = s_.frame_var[f];
    lin->U[a].template bottomRightCorner<3, 3>().diagonal().array() += prior_info_;
    lin->g_frame[a].template tail<3>() += prior_info_ * dw;
  }
}

template class SchurEvaluator<6>;
template class SchurEvaluator<9>;

}  // namespace rgbdmap::ba_detail
