#include "rgbdmap/ba/ba_cost.hpp"

#include <cmath>

namespace rgbdmap {
namespace {

constexpr double kMinDepth = 1e-6;  ///< a point this close to the camera plane makes the step fail

/// Whitened residual rows of p_rs and their derivative by p_rs.
template <int kRows>
void residualOf(const BaIntrinsics& k, const BaMeasurement& m, const Vec3& p, double* r,
                Eigen::Matrix<double, kRows, 3>* dr_dp) {
  const double iz = 1.0 / p.z(), inv_sigma = 1.0 / m.sigma_px;
  r[0] = (k.fx * p.x() * iz + k.cx - m.px.x()) * inv_sigma;
  r[1] = (k.fy * p.y() * iz + k.cy - m.px.y()) * inv_sigma;
  if constexpr (kRows == 3) r[2] = (iz - 1.0 / m.depth_m) / m.inverse_depth_sigma;
  if (!dr_dp) return;
  dr_dp->row(0) << k.fx * iz * inv_sigma, 0.0, -k.fx * p.x() * iz * iz * inv_sigma;
  dr_dp->row(1) << 0.0, k.fy * iz * inv_sigma, -k.fy * p.y() * iz * iz * inv_sigma;
  if constexpr (kRows == 3) dr_dp->row(2) << 0.0, 0.0, -iz * iz / m.inverse_depth_sigma;
}

}  // namespace

void poseToParams(const SE3& T_kf_map, double* params) {
  Eigen::Map<Eigen::Quaterniond> q(params);
  q = Eigen::Quaterniond(T_kf_map.linear()).normalized();
  Eigen::Map<Vec3> t(params + 4);
  t = T_kf_map.translation();
}

SE3 paramsToPose(const double* params) {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::Map<const Eigen::Quaterniond>(params).normalized().toRotationMatrix();
  T.translation() = Eigen::Map<const Vec3>(params + 4);
  return T;
}

Vec3 rollingShutterPoint(const Vec3& p_kf, const Vec3& w, double row_fraction) {
  return p_kf - row_fraction * w.cross(p_kf);
}

bool BaPoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Vec6 d = Eigen::Map<const Vec6>(delta);
  poseToParams(se3::exp(d) * paramsToPose(x), x_plus_delta);
  return true;
}

bool BaPoseManifold::PlusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topRows<6>().setIdentity();
  return true;
}

bool BaPoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Map<Vec6> d(y_minus_x);
  d = se3::log(paramsToPose(y) * paramsToPose(x).inverse());
  return true;
}

bool BaPoseManifold::MinusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<6>().setIdentity();
  return true;
}

template <int kRows>
bool observationJacobians(const BaIntrinsics& k, const BaMeasurement& m, const Mat3& R, const Vec3& t,
                          const Vec3& p_map, const Vec3& w, double* residual,
                          ObservationJacobians<kRows>* jacobians) {
  const Vec3 p = R * p_map + t;
  const double r = m.row_fraction;
  const Vec3 p_rs = rollingShutterPoint(p, w, r);
  if (p_rs.z() <= kMinDepth) return false;
  Eigen::Matrix<double, kRows, 3> dr_dprs;
  residualOf<kRows>(k, m, p_rs, residual, jacobians ? &dr_dprs : nullptr);
  if (!jacobians) return true;
  // p_rs = (I - r [w]x) p: d p_rs / d p = I - r [w]x; d p_rs / d w = r [p]x.
  const Eigen::Matrix<double, kRows, 3> dr_dp = dr_dprs * (Mat3::Identity() - r * se3::hat(w));
  jacobians->pose.template leftCols<3>() = dr_dp;  // d p / d delta = [I, -[p]x] (left perturbation)
  jacobians->pose.template rightCols<3>() = -dr_dp * se3::hat(p);
  jacobians->point = dr_dp * R;
  jacobians->w = r * dr_dprs * se3::hat(p);
  return true;
}

template <int kRows>
bool ObservationCost<kRows>::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  const Mat3 R = Eigen::Map<const Eigen::Quaterniond>(parameters[0]).toRotationMatrix();
  const Vec3 t = Eigen::Map<const Vec3>(parameters[0] + 4);
  const Vec3 p_map = Eigen::Map<const Vec3>(parameters[1]);
  const Vec3 w = Eigen::Map<const Vec3>(parameters[2]);
  ObservationJacobians<kRows> J;
  if (!observationJacobians<kRows>(k_, m_, R, t, p_map, w, residuals, jacobians ? &J : nullptr)) return false;
  if (!jacobians) return true;
  if (jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, kRows, 7, Eigen::RowMajor>> J0(jacobians[0]);
    J0.template leftCols<6>() = J.pose;
    J0.col(6).setZero();
  }
  using Map3 = Eigen::Map<Eigen::Matrix<double, kRows, 3, Eigen::RowMajor>>;
  if (jacobians[1]) {
    Map3 J1(jacobians[1]);
    J1 = J.point;
  }
  if (jacobians[2]) {
    Map3 J2(jacobians[2]);
    J2 = J.w;
  }
  return true;
}

bool RollingShutterPrior::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  Eigen::Map<Vec3> r(residuals);
  r = (Eigen::Map<const Vec3>(parameters[0]) - mean_) * inv_sigma_;
  if (jacobians && jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[0]);
    J = Mat3::Identity() * inv_sigma_;
  }
  return true;
}

template class ObservationCost<2>;
template class ObservationCost<3>;
template bool observationJacobians<2>(const BaIntrinsics&, const BaMeasurement&, const Mat3&, const Vec3&,
                                      const Vec3&, const Vec3&, double*, ObservationJacobians<2>*);
template bool observationJacobians<3>(const BaIntrinsics&, const BaMeasurement&, const Mat3&, const Vec3&,
                                      const Vec3&, const Vec3&, double*, ObservationJacobians<3>*);

ObservationResidual observationResidual(const BaIntrinsics& k, const SE3& T_kf_map, const Vec3& p_map,
                                        const Vec3& w, const BaMeasurement& m) {
  ObservationResidual out;
  const Vec3 p = rollingShutterPoint(T_kf_map * p_map, w, m.row_fraction);
  if (p.z() <= 1e-3) return out;
  out.in_front = true;
  double r[3];
  if (m.depth_m > 0.0) {
    residualOf<3>(k, m, p, r, nullptr);
    out.rows = 3;
  } else {
    residualOf<2>(k, m, p, r, nullptr);
    out.rows = 2;
  }
  for (int i = 0; i < out.rows; ++i) out.chi2 += r[i] * r[i];
  out.reprojection_px = Eigen::Vector2d(r[0], r[1]) * m.sigma_px;
  return out;
}

}  // namespace rgbdmap
