#include "rgbdmap/client/odometry_config_io.hpp"

#include "rgbdmap/common/common_config_tables.hpp"
#include "rgbdmap/dataset/dataset_config_table.hpp"
#include "rgbdmap/vision/vision_config_tables.hpp"

namespace rgbdmap {

const ConfigTable<KeyframeConfig>& keyframeConfigTable() {
  using C = KeyframeConfig;
  using R = ConfigRange;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("similarity_threshold", &C::similarity_threshold, R::closed(0.0, 1.0),
               "P: new keyframe when S < P")
          .add("max_frame_gap", &C::max_frame_gap, R::closed(1, 100000),
               "m: at most this many frames between keyframes")
          .add("max_translation_m", &C::max_translation_m, R::closed(0.001, 100.0), "or on large motion")
          .add("max_rotation_deg", &C::max_rotation_deg, R::closed(0.1, 180.0), "");
  return table;
}

const ConfigTable<OdometryConfig>& odometryConfigTable() {
  using C = OdometryConfig;
  using R = ConfigRange;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .nest("orb.", &C::orb, orbConfigTable())
          .section("matcher", "brute-force Hamming, then filters")
          .nest("matcher.", &C::matcher, matcherConfigTable())
          .section("guided", "matching by projection for the keyframe window")
          .nest("guided.", &C::guided, guidedMatchConfigTable())
          .section("ransac", "3-D <-> 3-D, closed-form minimal solver")
          .nest("ransac.", &C::ransac, ransacConfigTable())
          .section("refine", "robust Gauss-Newton on reprojection + depth residuals")
          .nest("refine.", &C::refine, refineConfigTable())
          .section("keyframe", "Hu et al. 2017: S = 2N / (N_t + N_k)")
          .nest("keyframe.", &C::keyframe, keyframeConfigTable())
          .add("window_keyframes", &C::window_keyframes, R::closed(1, 200),
               "keyframe poses refined against up to this many similar-view keyframes (1 = off)")
          .add("window_max_angle_deg", &C::window_max_angle_deg, R::closed(0.0, 180.0),
               "viewing-direction difference for a keyframe to join the window")
          .add("window_max_distance_m", &C::window_max_distance_m, R::closed(0.0, 100.0),
               "and camera-centre distance")
          .add("window_max_correction_m", &C::window_max_correction_m, R::closed(0.0, 10.0),
               "larger window corrections are rejected (loop closure is the server's job)")
          .add("window_max_correction_deg", &C::window_max_correction_deg, R::closed(0.0, 180.0), "")
          .add("window_every_frame", &C::window_every_frame,
               "also refine non-keyframes in the window (more accurate per frame, slower)")
          .add("relocalization_keyframes", &C::relocalization_keyframes, R::closed(0, 100),
               "recent keyframes tried when the reference keyframe fails")
          .add("min_tracking_inliers", &C::min_tracking_inliers, R::closed(3, 10000),
               "fewer is a tracking loss")
          .add("max_lost_frames", &C::max_lost_frames, R::closed(0, 100000),
               "then a new segment starts (flagged discontinuity)")
          .add("min_keyframe_points", &C::min_keyframe_points, R::closed(3, 100000),
               "features with depth needed for a keyframe")
          .add("trajectory_smoothing_s", &C::trajectory_smoothing_s, R::closed(0.0, 10.0),
               "the finished every-frame trajectory (not the live poses) is refit by a local quadratic in "
               "time over +- this (s) within each tracking segment; 0: off");
  return table;
}

void readCameraConfig(ConfigReader& r, const std::string& prefix, CameraIntrinsics* k) {
  cameraConfigTable().read(r, k, prefix);
}

void readOdometryConfig(ConfigReader& r, OdometryConfig* c) {
  odometryConfigTable().read(r, c, "odometry.");
  if (c->orb.min_depth_m >= c->orb.max_depth_m)
    r.addError("odometry.orb.min_depth_m must be below max_depth_m");
}

void readDatasetConfig(ConfigReader& r, DatasetOptions* options) {
  datasetConfigTable().read(r, options, "dataset.");
}

std::vector<ConfigValue> odometryFileValues(const CameraIntrinsics& camera, const DatasetOptions& dataset,
                                            const OdometryConfig& odometry) {
  std::vector<ConfigValue> out = {
      {"camera", "", "", "precedence: these < dataset camera.yaml < this file < --intrinsics/--depth-scale",
       false, true}};
  out = concatConfigValues(out, cameraConfigTable().values(camera, "camera."));
  out = concatConfigValues(out, datasetConfigTable().values(dataset, "dataset."));
  return concatConfigValues(out, odometryConfigTable().values(odometry, "odometry."));
}

std::vector<ConfigValue> defaultOdometryFileValues() {
  return odometryFileValues(CameraIntrinsics(), DatasetOptions(), OdometryConfig());
}

}  // namespace rgbdmap
