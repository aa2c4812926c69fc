#pragma once
// Matching by projection: with a pose estimate, a keyframe's 3-D points are projected into the current
// image and compared only with the current keypoints nearby. Used to add a window of keyframes to a pose
// that brute-force matching against the reference keyframe already found (ORB-SLAM's local-map idea).
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/vision/features.hpp"
#include "rgbdmap/vision/guided_match_config.hpp"
#include "rgbdmap/vision/matcher.hpp"

namespace rgbdmap {

/// Buckets the current frame's undistorted keypoints for radius queries.
class FeatureGrid {
 public:
  FeatureGrid(const FrameFeatures& features, int width, int height, int cell_px = 16);
  /// Indices of keypoints within `radius` of (x, y) (cell-level candidates, exact distance checked).
  void query(double x, double y, double radius, std::vector<int>* out) const;

 private:
  const FrameFeatures& features_;
  int cell_, cols_, rows_;
  std::vector<std::vector<int>> cells_;
};

/// Matches keyframe features with depth to current keypoints near their projection under T_cur_kf.
/// One-to-one on the current side (the closest descriptor wins).
std::vector<FeatureMatch> matchByProjection(const FrameFeatures& cur, const FeatureGrid& grid,
                                            const FrameFeatures& kf, const SE3& T_cur_kf,
                                            const PinholeCamera& camera, const GuidedMatchConfig& config);

}  // namespace rgbdmap
