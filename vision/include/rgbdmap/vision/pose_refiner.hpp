#pragma once
// Robust Gauss-Newton refinement of a relative pose on reprojection + depth residuals.
#include <vector>

#include "rgbdmap/vision/ransac.hpp"
#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

struct RefineResult {
  SE3 T_cur_ref = SE3::Identity();
  std::vector<char> inlier_mask;  ///< per input match (always matches.size() entries)
  int inliers = 0;
  double rms_whitened = 0.0;        ///< RMS of whitened residual norms over inliers
  Mat6 information = Mat6::Zero();  ///< J^T W J over inliers; tangent order (rho, omega), left perturbation
  bool converged = false;
};

/// Whitened residual of one match under T_cur_ref: 2 reprojection rows (px / sigma) and, when the current
/// frame has depth there (p_cur.z() > 0), 1 depth row ((z_pred - z_obs) / sigma_z), else a zero row. Returns
/// the number of informative rows (0 if the point is behind the camera). If J is not null it receives d r / d
/// xi for T <- exp(xi) * T.
int matchResidual(const PointMatch& m, const SE3& T_cur_ref, const PinholeCamera& camera,
                  const RefineConfig& config, Eigen::Vector3d* r, Eigen::Matrix<double, 3, 6>* J);

/// Minimises the Huber-weighted sum of squared whitened residuals starting from T_init, re-classifying
/// outliers (chi2 test) between rounds. Matches with p_ref.z() <= 0 are ignored.
RefineResult refinePose(const std::vector<PointMatch>& matches, const SE3& T_init,
                        const PinholeCamera& camera, const RefineConfig& config);

}  // namespace rgbdmap
