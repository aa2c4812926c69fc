#include "rgbdmap/graph/pose_graph_cost.hpp"

#include <ceres/manifold.h>

#include <cmath>

namespace rgbdmap {
namespace {

/// J_l^-1 of SO(3).
Mat3 leftJacobianInverseSO3(const Vec3& w) {
  const double theta2 = w.squaredNorm();
  double coef = 1.0 / 12.0 + theta2 / 720.0;
  if (theta2 >= 1e-4) {
    const double half = 0.5 * std::sqrt(theta2);
    coef = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  }
  const Mat3 W = se3::hat(w);
  return Mat3::Identity() - 0.5 * W + coef * W * W;
}

/// Barfoot's Q(rho, phi): the off-diagonal block of the SE(3) left Jacobian.
Mat3 barfootQ(const Vec3& rho, const Vec3& phi) {
  const double t2 = phi.squaredNorm();
  double c1 = 1.0 / 6.0 - t2 / 120.0, c2 = 1.0 / 24.0 - t2 / 720.0, c3 = 1.0 / 120.0 - t2 / 2520.0;
  if (t2 >= 1e-4) {
    const double t = std::sqrt(t2), s = std::sin(t), c = std::cos(t);
    c1 = (t - s) / (t2 * t);
    c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t2 * t2);
    c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t2 * t2 * t);
  }
  const Mat3 P = se3::hat(phi), R = se3::hat(rho);
  const Mat3 PR = P * R, RP = R * P, PRP = PR * P;
  return 0.5 * R + c1 * (PR + RP + PRP) + c2 * (P * PR + RP * P - 3.0 * PRP) + c3 * (PRP * P + P * PRP);
}

Mat6 adjoint(const SE3& T) {
  Mat6 ad = Mat6::Zero();
  ad.block<3, 3>(0, 0) = T.linear();
  ad.block<3, 3>(0, 3) = se3::hat(T.translation()) * T.linear();
  ad.block<3, 3>(3, 3) = T.linear();
  return ad;
}

/// Writes L * [dxi/dphi | dxi/dt] (tangent, 6x6) into a row-major 6x7 ambient Jacobian. Ceres' quaternion
/// Plus is [cos|d|, sin|d| d/|d|] * q, a left rotation by phi = 2 d, and its PlusJacobian P has orthonormal
/// columns (P^T P = I), so the ambient block 2 * J_phi * P^T gives back J_phi * dphi/dd after Ceres' product.
void writeAmbient(const Mat6& J_tangent, const double* q, double* out) {
  Eigen::Matrix<double, 4, 3, Eigen::RowMajor> P;
  ceres::EigenQuaternionManifold().PlusJacobian(q, P.data());
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(out);
  J.leftCols<4>() = 2.0 * J_tangent.leftCols<3>() * P.transpose();
  J.rightCols<3>() = J_tangent.rightCols<3>();
}

SE3 poseOf(const double* p) {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::Map<const Eigen::Quaterniond>(p).toRotationMatrix();
  T.translation() = Eigen::Map<const Vec3>(p + 4);
  return T;
}

}  // namespace

Mat6 rightJacobianInverseSE3(const Vec6& xi) {
  // Jr^-1(xi) = Jl^-1(-xi) = [[A, -A Q A], [0, A]] with A = J_l^-1(-omega), Q = Q(-rho, -omega).
  const Vec3 rho = -xi.head<3>(), w = -xi.tail<3>();
  const Mat3 A = leftJacobianInverseSO3(w);
  Mat6 J = Mat6::Zero();
  J.block<3, 3>(0, 0) = A;
  J.block<3, 3>(3, 3) = A;
  J.block<3, 3>(0, 3) = -A * barfootQ(rho, w) * A;
  return J;
}

bool RelativePoseCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const SE3 T_map_from = poseOf(parameters[0]), T_map_to = poseOf(parameters[1]);
  const SE3 T_from_to_est = T_map_from.inverse() * T_map_to;
  const Vec6 xi = se3::log(T_to_from_ * T_from_to_est);
  Eigen::Map<Vec6> r(residuals);
  r = sqrt_information_ * xi;
  if (!jacobians) return true;
  const Mat6 LJ = sqrt_information_ * rightJacobianInverseSE3(xi);
  // A node perturbed by (phi, dt) moves as T_map_kf * exp(eta) with eta = (R^T dt, R^T phi).
  const auto tangentOf = [](const Mat6& d_eta, const Mat3& R_kf_map) {
    Mat6 J;
    J.leftCols<3>() = d_eta.rightCols<3>() * R_kf_map;  // rotation (phi)
    J.rightCols<3>() = d_eta.leftCols<3>() * R_kf_map;  // translation (dt)
    return J;
  };
  if (jacobians[0]) {  // E = Z^-1 exp(-eta) T_rel = E exp(-Ad(T_rel^-1) eta)
    const Mat6 d_eta = -LJ * adjoint(T_from_to_est.inverse());
    writeAmbient(tangentOf(d_eta, T_map_from.linear().transpose()), parameters[0], jacobians[0]);
  }
  if (jacobians[1]) writeAmbient(tangentOf(LJ, T_map_to.linear().transpose()), parameters[1], jacobians[1]);
  return true;
}

}  // namespace rgbdmap
