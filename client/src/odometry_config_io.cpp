#include "rgbdmap/client/odometry_config_io.hpp"

namespace rgbdmap {

void readCameraConfig(ConfigReader& r, const std::string& p, CameraIntrinsics* k) {
  r.read(p + "fx", &k->fx, 1.0, 1e5);
  r.read(p + "fy", &k->fy, 1.0, 1e5);
  r.read(p + "cx", &k->cx, -1e5, 1e5);
  r.read(p + "cy", &k->cy, -1e5, 1e5);
  r.read(p + "width", &k->width, 1, 16384);
  r.read(p + "height", &k->height, 1, 16384);
  r.readList(p + "distortion", k->distortion.data(), k->distortion.size());
  r.read(p + "depth_scale", &k->depth_scale, 1e-6, 1e9);
}

void readOdometryConfig(ConfigReader& r, OdometryConfig* c) {
  const std::string o = "odometry.";
  r.read(o + "orb.n_features", &c->orb.n_features, 50, 20000);
  r.read(o + "orb.scale_factor", &c->orb.scale_factor, 1.01f, 2.0f);
  r.read(o + "orb.n_levels", &c->orb.n_levels, 1, 16);
  r.read(o + "orb.fast_threshold", &c->orb.fast_threshold, 1, 100);
  r.read(o + "orb.grid_cols", &c->orb.grid_cols, 1, 64);
  r.read(o + "orb.grid_rows", &c->orb.grid_rows, 1, 64);
  r.read(o + "orb.min_depth_m", &c->orb.min_depth_m, 0.0, 100.0);
  r.read(o + "orb.max_depth_m", &c->orb.max_depth_m, 0.01, 100.0);
  r.read(o + "matcher.k_min_distance", &c->matcher.k_min_distance, 1.0, 100.0);
  r.read(o + "matcher.min_distance_floor", &c->matcher.min_distance_floor, 0, 256);
  r.read(o + "matcher.max_distance", &c->matcher.max_distance, 1, 256);
  r.read(o + "matcher.ratio", &c->matcher.ratio, 0.1, 1.0);
  r.read(o + "ransac.max_iterations", &c->ransac.max_iterations, 1, 100000);
  r.read(o + "ransac.confidence", &c->ransac.confidence, 0.5, 0.999999);
  r.read(o + "ransac.reprojection_threshold_px", &c->ransac.reprojection_threshold_px, 0.1, 100.0);
  r.read(o + "ransac.depth_threshold_rel", &c->ransac.depth_threshold_rel, 0.001, 1.0);
  r.read(o + "ransac.min_inliers", &c->ransac.min_inliers, 3, 10000);
  r.read(o + "ransac.seed", &c->ransac.seed, 0u, 4294967295u);
  r.read(o + "refine.iterations", &c->refine.iterations, 0, 100);
  r.read(o + "refine.rounds", &c->refine.rounds, 1, 10);
  r.read(o + "refine.pixel_sigma", &c->refine.pixel_sigma, 0.01, 100.0);
  r.read(o + "refine.depth_sigma_coeff", &c->refine.depth_sigma_coeff, 1e-6, 1.0);
  r.read(o + "refine.huber_delta", &c->refine.huber_delta, 0.01, 100.0);
  r.read(o + "refine.outlier_chi2", &c->refine.outlier_chi2, 0.1, 1000.0);
  r.read(o + "keyframe.similarity_threshold", &c->keyframe.similarity_threshold, 0.0, 1.0);
  r.read(o + "keyframe.max_frame_gap", &c->keyframe.max_frame_gap, 1, 100000);
  r.read(o + "keyframe.max_translation_m", &c->keyframe.max_translation_m, 0.001, 100.0);
  r.read(o + "keyframe.max_rotation_deg", &c->keyframe.max_rotation_deg, 0.1, 180.0);
  r.read(o + "window_keyframes", &c->window_keyframes, 1, 200);
  r.read(o + "window_max_angle_deg", &c->window_max_angle_deg, 0.0, 180.0);
  r.read(o + "window_max_distance_m", &c->window_max_distance_m, 0.0, 100.0);
  r.read(o + "window_max_correction_m", &c->window_max_correction_m, 0.0, 10.0);
  r.read(o + "window_max_correction_deg", &c->window_max_correction_deg, 0.0, 180.0);
  r.read(o + "window_every_frame", &c->window_every_frame);
  r.read(o + "guided.radius_px", &c->guided.radius_px, 0.5, 200.0);
  r.read(o + "guided.max_distance", &c->guided.max_distance, 1, 256);
  r.read(o + "guided.ratio", &c->guided.ratio, 0.1, 1.0);
  r.read(o + "relocalization_keyframes", &c->relocalization_keyframes, 0, 100);
  r.read(o + "min_tracking_inliers", &c->min_tracking_inliers, 3, 10000);
  r.read(o + "max_lost_frames", &c->max_lost_frames, 0, 100000);
  r.read(o + "min_keyframe_points", &c->min_keyframe_points, 3, 100000);
  if (c->orb.min_depth_m >= c->orb.max_depth_m)
    r.addError("odometry.orb.min_depth_m must be below max_depth_m");
}

}  // namespace rgbdmap
