#include "rgbdmap/backend/edge_information.hpp"

#include <cmath>

#include <Eigen/Cholesky>

namespace rgbdmap {

bool isPositiveDefinite(const Mat6& m) {
  if (!m.allFinite() || !m.isApprox(m.transpose(), 1e-9 * (1.0 + m.norm()))) return false;
  const Eigen::LLT<Mat6> llt(0.5 * (m + m.transpose()));
  return llt.info() == Eigen::Success;
}

Mat6 withCovarianceFloor(const Mat6& information, double sigma_t, double sigma_r) {
  Mat6 floor = Mat6::Zero();
  floor.diagonal() << sigma_t * sigma_t, sigma_t * sigma_t, sigma_t * sigma_t, sigma_r * sigma_r,
      sigma_r * sigma_r, sigma_r * sigma_r;
  const Eigen::LDLT<Mat6> ldlt(0.5 * (information + information.transpose()));
  const Mat6 cov = ldlt.solve(Mat6::Identity());
  Mat6 out = (0.5 * (cov + cov.transpose()) + floor).inverse();
  return 0.5 * (out + out.transpose());
}

Mat6 flooredInformation(const Mat6& information, const EdgeInformationConfig& config) {
  if (config.edge_sigma_floor_m <= 0.0 && config.edge_sigma_floor_deg <= 0.0) return information;
  return withCovarianceFloor(information, config.edge_sigma_floor_m,
                             config.edge_sigma_floor_deg * M_PI / 180.0);
}

Mat6 odometryInformation(const Mat6& reported, const EdgeInformationConfig& config) {
  if (isPositiveDefinite(reported)) return flooredInformation(reported, config);
  const double st = config.default_odometry_sigma_m;
  const double sr = config.default_odometry_sigma_deg * M_PI / 180.0;
  Mat6 info = Mat6::Zero();
  info.diagonal() << 1 / (st * st), 1 / (st * st), 1 / (st * st), 1 / (sr * sr), 1 / (sr * sr), 1 / (sr * sr);
  return info;
}

Mat6 loopInformation(const Mat6& reported, const EdgeInformationConfig& config) {
  return isPositiveDefinite(reported) ? flooredInformation(reported, config) : reported;
}

}  // namespace rgbdmap
