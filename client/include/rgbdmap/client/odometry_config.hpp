#pragma once
// Configuration of the client's visual odometry. Plain structs with documented defaults; apps load them
// from YAML (odometry_config_io.hpp, example with every key in deploy/config/odometry.yaml).
#include "rgbdmap/vision/guided_match_config.hpp"
#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

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
  int relocalization_keyframes = 15;  ///< recent keyframes tried when tracking against the last one fails
  int min_tracking_inliers = 20;     ///< fewer inliers than this is a tracking loss
  int max_lost_frames = 10;          ///< after this many lost frames a new segment starts at the prediction
  int min_keyframe_points = 50;      ///< a keyframe needs at least this many features with depth
  /// The finished every-frame trajectory (trajectory_<robot>.txt, not the live poses) is smoothed by a local
  /// quadratic in time over +-this many seconds (smoothTrajectory); 0: off.
  double trajectory_smoothing_s = 0.3;
};

}  // namespace rgbdmap
