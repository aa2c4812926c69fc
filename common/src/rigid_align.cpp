#include "rgbdmap/common/rigid_align.hpp"

#include <Eigen/SVD>

namespace rgbdmap {

std::optional<SE3> alignPointSets(const Vec3* src, const Vec3* dst, size_t n, const double* weights) {
  if (n < 3) return std::nullopt;
  double w_sum = 0;
  Vec3 mu_src = Vec3::Zero(), mu_dst = Vec3::Zero();
  for (size_t i = 0; i < n; ++i) {
    const double w = weights ? weights[i] : 1.0;
    if (!src[i].allFinite() || !dst[i].allFinite() || !(w >= 0)) return std::nullopt;
    w_sum += w;
    mu_src += w * src[i];
    mu_dst += w * dst[i];
  }
  if (!(w_sum > 0)) return std::nullopt;
  mu_src /= w_sum;
  mu_dst /= w_sum;
  Mat3 cov = Mat3::Zero();
  double spread = 0;
  for (size_t i = 0; i < n; ++i) {
    const double w = weights ? weights[i] : 1.0;
    const Vec3 a = src[i] - mu_src;
    cov += w * (dst[i] - mu_dst) * a.transpose();
    spread += w * a.squaredNorm();
  }
  const Eigen::JacobiSVD<Mat3> svd(cov, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 sv = svd.singularValues();
  // Collinear or coincident points leave the rotation about their line undetermined.
  if (!(spread > 0) || sv(1) < 1e-9 * std::max(sv(0), 1e-300)) return std::nullopt;
  Mat3 S = Mat3::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(2, 2) = -1;
  SE3 T = SE3::Identity();
  T.linear() = svd.matrixU() * S * svd.matrixV().transpose();
  T.translation() = mu_dst - T.linear() * mu_src;
  return T;
}

}  // namespace rgbdmap
