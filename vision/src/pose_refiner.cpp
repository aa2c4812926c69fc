#include "rgbdmap/vision/pose_refiner.hpp"

#include <cmath>

#include <Eigen/Cholesky>

namespace rgbdmap {

int matchResidual(const PointMatch& m, const SE3& T, const PinholeCamera& camera, const RefineConfig& config,
                  Eigen::Vector3d* r, Eigen::Matrix<double, 3, 6>* J) {
  const Vec3 q = T * m.p_ref;
  if (q.z() < 1e-3) return 0;
  const auto& k = camera.intrinsics();
  const double iz = 1.0 / q.z();
  const double sigma_px = config.pixel_sigma * m.sigma_px;
  (*r)(0) = (k.fx * q.x() * iz + k.cx - m.px_cur.x()) / sigma_px;
  (*r)(1) = (k.fy * q.y() * iz + k.cy - m.px_cur.y()) / sigma_px;
  const bool has_depth = m.p_cur.z() > 0;
  double sigma_z = 1.0;
  if (has_depth) {
    const double zc = m.p_cur.z(), zr = q.z();
    sigma_z = config.depth_sigma_coeff * std::sqrt(zc * zc * zc * zc + zr * zr * zr * zr) + 1e-4;
    (*r)(2) = (q.z() - zc) / sigma_z;
  } else {
    (*r)(2) = 0.0;
  }
  if (J) {
    // d q / d xi = [I, -[q]x] for a left perturbation T <- exp(xi) * T.
    Eigen::Matrix<double, 3, 6> dq;
    dq.leftCols<3>().setIdentity();
    dq.rightCols<3>() = -se3::hat(q);
    Eigen::Matrix<double, 3, 3> dr_dq = Eigen::Matrix3d::Zero();
    dr_dq.row(0) << k.fx * iz, 0, -k.fx * q.x() * iz * iz;
    dr_dq.row(1) << 0, k.fy * iz, -k.fy * q.y() * iz * iz;
    dr_dq.topRows<2>() /= sigma_px;
    if (has_depth) dr_dq.row(2) << 0, 0, 1.0 / sigma_z;
    *J = dr_dq * dq;
  }
  return has_depth ? 3 : 2;
}

namespace {

double chi2Threshold(int rows, const RefineConfig& config) {
  // outlier_chi2 is given for 3 dof; scale the 2-dof case by the ratio of 95% quantiles (5.991 / 7.815).
  return rows == 3 ? config.outlier_chi2 : config.outlier_chi2 * (5.991 / 7.815);
}

// One Gauss-Newton solve over the active matches; returns false if the system is singular.
bool gaussNewtonStep(const std::vector<PointMatch>& matches, const std::vector<char>& active, SE3* T,
                     const PinholeCamera& camera, const RefineConfig& config, double* step_norm) {
  Mat6 H = Mat6::Zero();
  Vec6 b = Vec6::Zero();
  Eigen::Vector3d r;
  Eigen::Matrix<double, 3, 6> J;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (!active[i]) continue;
    const int rows = matchResidual(matches[i], *T, camera, config, &r, &J);
    if (rows == 0) continue;  // the third row is zero when there is no depth
    const double e = r.norm();
    const double w = e <= config.huber_delta ? 1.0 : config.huber_delta / e;
    H.noalias() += w * J.transpose() * J;
    b.noalias() += w * J.transpose() * r;
  }
  const Eigen::LDLT<Mat6> ldlt(H);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  const Vec6 dx = ldlt.solve(-b);
  if (!dx.allFinite()) return false;
  *T = se3::normalized(se3::exp(dx) * (*T));
  *step_norm = dx.norm();
  return true;
}

}  // namespace

RefineResult refinePose(const std::vector<PointMatch>& matches, const SE3& T_init,
                        const PinholeCamera& camera, const RefineConfig& config) {
  RefineResult out;
  out.T_cur_ref = T_init;
  std::vector<char> active(matches.size());
  for (size_t i = 0; i < matches.size(); ++i) active[i] = matches[i].p_ref.z() > 0;
  Eigen::Vector3d r;
  Eigen::Matrix<double, 3, 6> J;
  for (int round = 0; round < config.rounds; ++round) {
    for (int it = 0; it < config.iterations; ++it) {
      double step = 0;
      if (!gaussNewtonStep(matches, active, &out.T_cur_ref, camera, config, &step)) {
        // Degenerate system (too few or collinear points): no pose, no inliers, but a mask of full size.
        out.T_cur_ref = T_init;
        out.inlier_mask.assign(matches.size(), 0);
        return out;
      }
      if (step < 1e-9) {
        out.converged = true;
        break;
      }
    }
    // Re-classify: outliers leave, returning inliers come back (chi2 on whitened residuals).
    for (size_t i = 0; i < matches.size(); ++i) {
      if (matches[i].p_ref.z() <= 0) continue;
      const int rows = matchResidual(matches[i], out.T_cur_ref, camera, config, &r, nullptr);
      active[i] = rows > 0 && r.squaredNorm() <= chi2Threshold(rows, config);
    }
  }
  double sum_sq = 0;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (!active[i]) continue;
    if (matchResidual(matches[i], out.T_cur_ref, camera, config, &r, &J) == 0) continue;
    out.information.noalias() += J.transpose() * J;
    sum_sq += r.squaredNorm();
    ++out.inliers;
  }
  out.rms_whitened = out.inliers ? std::sqrt(sum_sq / out.inliers) : 0.0;
  out.inlier_mask = std::move(active);
  return out;
}

}  // namespace rgbdmap
