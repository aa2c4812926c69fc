#pragma once
// Configuration of the shared vision pipeline (ORB extraction, matching, RANSAC, refinement) used by the
// robot's odometry and the server's loop verification. Plain structs with documented defaults; the apps
// load them from YAML (rgbdmap/client/odometry_config_io.hpp, every key in deploy/config/odometry.yaml).

namespace rgbdmap {

struct OrbConfig {
  int n_features = 1000;      ///< target keypoints per frame after grid bucketing
  float scale_factor = 1.2f;  ///< pyramid scale between levels
  int n_levels = 8;           ///< pyramid levels
  int fast_threshold = 20;    ///< FAST corner threshold
  int grid_cols = 8;          ///< bucketing grid so features spread over the image
  int grid_rows = 6;
  double min_depth_m = 0.3;  ///< depth outside [min, max] counts as missing
  double max_depth_m = 6.0;
  /// A keypoint's depth also counts as missing where the valid depth within this many pixels of it spans
  /// more than depth_edge_max_spread of it: on a depth discontinuity the depth and colour images disagree
  /// (registration, the time between the two exposures), so the pixel's depth may belong to the other
  /// side of the edge. 0 turns the test off.
  int depth_edge_radius_px = 3;
  double depth_edge_max_spread = 0.03;  ///< (max - min) / depth over that window
};

struct MatcherConfig {
  double k_min_distance = 4.0;  ///< Hu et al. 2017: drop matches with distance > k x minimum distance
  int min_distance_floor = 30;  ///< ... but never drop a match below this Hamming distance
  int max_distance = 80;        ///< hard upper bound on Hamming distance (256-bit descriptors)
  double ratio = 0.85;          ///< Lowe ratio test between best and second-best (1 disables)
};

struct RansacConfig {
  int max_iterations = 300;
  double confidence = 0.995;
  double reprojection_threshold_px = 4.0;  ///< inlier if the reprojection error is below this ...
  double depth_threshold_rel = 0.08;       ///< ... and the depth agrees within this fraction of the depth
  int min_inliers = 15;
  unsigned seed = 42;  ///< deterministic sampling
};

struct RefineConfig {
  int iterations = 10;       ///< Gauss-Newton iterations per round
  int rounds = 2;            ///< rounds of (optimise, re-classify outliers)
  double pixel_sigma = 1.0;  ///< keypoint noise at pyramid level 0, px (scaled by scale_factor^level)
  double depth_sigma_coeff = 0.0016;  ///< depth noise sigma = coeff * z^2 (m), Kinect-like
  double huber_delta = 2.4477;        ///< robust kernel on whitened residual norms (sqrt(chi2_2dof 95%))
  double outlier_chi2 = 7.815;  ///< whitened squared error above which a match is an outlier (3 dof 95%)
};

}  // namespace rgbdmap
