#pragma once
// RANSAC over 3-D <-> 3-D correspondences with a closed-form (Umeyama/SVD) minimal solver.
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/vision/features.hpp"
#include "rgbdmap/vision/matcher.hpp"
#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

/// One putative correspondence: a 3-D point of the reference frame and the current frame's observation.
struct PointMatch {
  Vec3 p_ref;              ///< point in the reference camera frame
  Vec3 p_cur;              ///< point in the current camera frame (from its own depth)
  Eigen::Vector2d px_cur;  ///< undistorted pixel in the current image
  Eigen::Vector2d px_ref;  ///< undistorted pixel in the reference image
  double sigma_px = 1.0;   ///< keypoint position noise (grows with pyramid level)
};

/// Correspondences between the current frame and a reference frame's features (which must have depth);
/// sigma_px grows with the current keypoint's pyramid level (scale_factor^octave).
std::vector<PointMatch> toPointMatches(const FrameFeatures& cur, const FrameFeatures& ref,
                                       const std::vector<FeatureMatch>& matches, float scale_factor);

struct RansacResult {
  bool success = false;
  SE3 T_cur_ref = SE3::Identity();
  std::vector<int> inliers;  ///< indices into the input matches
  int iterations = 0;
};

/// Inlier test shared by RANSAC and the refiner: reprojection within threshold and consistent depth.
bool isGeometricInlier(const PointMatch& m, const SE3& T_cur_ref, const PinholeCamera& camera,
                       const RansacConfig& config);

/// Estimates T_cur_ref. Samples 3 matches, rejects samples whose pairwise distances disagree, solves
/// in closed form, scores by isGeometricInlier, adapts the iteration count to the inlier ratio, and
/// re-estimates on all inliers of the best hypothesis. Deterministic for a given config.seed.
RansacResult ransacRigid(const std::vector<PointMatch>& matches, const PinholeCamera& camera,
                         const RansacConfig& config);

}  // namespace rgbdmap
