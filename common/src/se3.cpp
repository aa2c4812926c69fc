#include "rgbdmap/common/se3.hpp"

#include <algorithm>
#include <cmath>

namespace rgbdmap::se3 {

Mat3 hat(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Mat3 expSO3(const Vec3& omega) {
  const double theta = omega.norm();
  if (theta < 1e-10) return Mat3::Identity() + hat(omega);
  return Eigen::AngleAxisd(theta, omega / theta).toRotationMatrix();
}

Vec3 logSO3(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  Vec3 v = aa.angle() * aa.axis();
  return v;
}

namespace {
// Left Jacobian of SO(3) and its inverse, used to couple translation and rotation in SE(3).
Mat3 leftJacobian(const Vec3& omega) {
  const double theta = omega.norm();
  const Mat3 W = hat(omega);
  if (theta < 1e-8) return Mat3::Identity() + 0.5 * W;
  const double t2 = theta * theta;
  return Mat3::Identity() + (1 - std::cos(theta)) / t2 * W + (theta - std::sin(theta)) / (t2 * theta) * W * W;
}

Mat3 leftJacobianInverse(const Vec3& omega) {
  const double theta = omega.norm();
  const Mat3 W = hat(omega);
  if (theta < 1e-8) return Mat3::Identity() - 0.5 * W;
  const double half = 0.5 * theta;
  const double coef = (1.0 - half * std::cos(half) / std::sin(half)) / (theta * theta);
  return Mat3::Identity() - 0.5 * W + coef * W * W;
}
}  // namespace

SE3 exp(const Vec6& xi) {
  const Vec3 rho = xi.head<3>();
  const Vec3 omega = xi.tail<3>();
  SE3 T = SE3::Identity();
  T.linear() = expSO3(omega);
  T.translation() = leftJacobian(omega) * rho;
  return T;
}

Vec6 log(const SE3& T) {
  Vec6 xi;
  const Vec3 omega = logSO3(T.linear());
  xi.tail<3>() = omega;
  xi.head<3>() = leftJacobianInverse(omega) * T.translation();
  return xi;
}

SE3 fromQuatTrans(const Eigen::Quaterniond& q, const Vec3& t) {
  SE3 T = SE3::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

SE3 fromTum(double tx, double ty, double tz, double qx, double qy, double qz, double qw) {
  return fromQuatTrans(Eigen::Quaterniond(qw, qx, qy, qz), Vec3(tx, ty, tz));
}

Eigen::Quaterniond quat(const SE3& T) {
  Eigen::Quaterniond q(T.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  return q;
}

SE3 interpolate(const SE3& a, const SE3& b, double alpha) {
  const Eigen::Quaterniond qa = quat(a), qb = quat(b);
  SE3 T = SE3::Identity();
  T.linear() = qa.slerp(alpha, qb).toRotationMatrix();
  T.translation() = (1 - alpha) * a.translation() + alpha * b.translation();
  return T;
}

double rotationAngle(const SE3& T) { return Eigen::AngleAxisd(T.linear()).angle(); }

bool isValid(const SE3& T, double tol) {
  if (!T.matrix().allFinite()) return false;
  const Mat3 R = T.linear();
  return (R.transpose() * R - Mat3::Identity()).norm() < tol && std::abs(R.determinant() - 1.0) < tol;
}

SE3 normalized(const SE3& T) {
  SE3 out = T;
  out.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return out;
}

Vec3 eulerRPY(const Mat3& R) {
  // R = Rz(yaw) * Ry(pitch) * Rx(roll)
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  return {roll, pitch, yaw};
}

}  // namespace rgbdmap::se3
