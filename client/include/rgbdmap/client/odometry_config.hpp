#pragma once
// Configuration of the client's visual odometry. Plain structs with documented defaults; apps load them
// from YAML (odometry_config_io.hpp, example with every key in deploy/config/odometry.yaml).
#include "rgbdmap/client/guided_match_config.hpp"

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

struct KeyframeConfig {
  double similarity_threshold = 0.30;  ///< P: new keyframe when S = 2N / (N_t + N_k) < P
  int max_frame_gap = 30;              ///< m: new keyframe after at most this many frames
  double max_translation_m = 0.25;     ///< ... or on large motion from the keyframe
  double max_rotation_deg = 15.0;
};

struct OdometryConfig {
  OrbConfig orb;
  MatcherConfig matcher;
  GuidedMatchConfig guided;
  RansacConfig ransac;
  RefineConfig refine;
  KeyframeConfig keyframe;
  /// Window refinement: a new keyframe's pose (or every frame's, with window_every_frame) is refined
  /// jointly against up to this many keyframes of similar viewpoint, matched by projection. 1 disables.
  int window_keyframes = 20;
  double window_max_angle_deg = 45.0;      ///< viewing-direction difference for a keyframe to join the window
  double window_max_distance_m = 0.6;      ///< and camera-centre distance
  double window_max_correction_m = 0.025;  ///< a window result moving the pose more than this is rejected
  double window_max_correction_deg = 2.0;  ///< ... or rotating it more than this
  bool window_every_frame = false;
  int relocalization_keyframes = 5;  ///< recent keyframes tried when tracking against the last one fails
  int min_tracking_inliers = 20;     ///< fewer inliers than this is a tracking loss
  int max_lost_frames = 10;          ///< after this many lost frames a new segment starts at the prediction
  int min_keyframe_points = 50;      ///< a keyframe needs at least this many features with depth
};

}  // namespace rgbdmap
