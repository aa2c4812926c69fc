#include "rgbdmap/common/alignment.hpp"

#include <algorithm>

#include <Eigen/SVD>

namespace rgbdmap {
namespace {

/// Singular values below this fraction of the largest count as zero (exactly collinear data gives ~1e-16).
constexpr double kRankTolerance = 1e-10;

bool allFinite(const std::vector<Vec3>& points) {
  for (const Vec3& p : points)
    if (!p.allFinite()) return false;
  return true;
}

Vec3 mean(const std::vector<Vec3>& points) {
  Vec3 sum = Vec3::Zero();
  for (const Vec3& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

}  // namespace

Result<Alignment> solveAlignment(const std::vector<Vec3>& est, const std::vector<Vec3>& gt, bool with_scale) {
  using R = Result<Alignment>;
  if (est.size() != gt.size())
    return R::failure("alignment: " + std::to_string(est.size()) + " estimated but " +
                      std::to_string(gt.size()) + " ground-truth points");
  if (est.empty()) return R::failure("alignment: no point pairs");
  if (!allFinite(est) || !allFinite(gt)) return R::failure("alignment: non-finite point coordinates");

  const Vec3 mu_est = mean(est), mu_gt = mean(gt);
  const double n = static_cast<double>(est.size());
  Mat3 sigma = Mat3::Zero();  // cross-covariance (1/n) sum (gt - mu_gt)(est - mu_est)^T
  double var_est = 0.0;
  for (size_t i = 0; i < est.size(); ++i) {
    sigma += (gt[i] - mu_gt) * (est[i] - mu_est).transpose();
    var_est += (est[i] - mu_est).squaredNorm();
  }
  sigma /= n;
  var_est /= n;

  const Eigen::JacobiSVD<Mat3> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Vec3 d = svd.singularValues();  // descending
  Mat3 S = Mat3::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;  // no reflections

  Alignment a;
  a.unique = d(1) > kRankTolerance * d(0) && d(0) > 0;
  if (with_scale) {
    if (!(var_est > 0)) return R::failure("alignment: estimated points all coincide, scale is undefined");
    a.scale = (d.asDiagonal() * S).trace() / var_est;
  }
  const Mat3 R_gt_est = svd.matrixU() * S * svd.matrixV().transpose();
  a.T_gt_est.linear() = R_gt_est;
  a.T_gt_est.translation() = mu_gt - a.scale * R_gt_est * mu_est;
  return a;
}

Result<Alignment> alignUmeyama(const std::vector<Vec3>& est, const std::vector<Vec3>& gt, bool with_scale) {
  if (est.size() < 3 || gt.size() < 3)
    return Result<Alignment>::failure("alignment: needs at least 3 point pairs, got " +
                                      std::to_string(std::min(est.size(), gt.size())));
  auto a = solveAlignment(est, gt, with_scale);
  if (a && !a->unique)
    return Result<Alignment>::failure(
        "alignment: points are collinear (or coincide), rotation is not unique");
  return a;
}

Result<SE3> alignRigid(const std::vector<Vec3>& est, const std::vector<Vec3>& gt) {
  auto a = alignUmeyama(est, gt, false);
  if (!a) return Result<SE3>::failure(a.error());
  return a->T_gt_est;
}

}  // namespace rgbdmap
