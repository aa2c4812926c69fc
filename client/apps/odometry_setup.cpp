#include "odometry_setup.hpp"

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::app {

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
  r.read(o + "orb.min_fast_threshold", &c->orb.min_fast_threshold, 1, 100);
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

namespace {

void applyOverrides(cli::Args& args, OdometrySetup* s, std::vector<std::string>* errors) {
  if (auto list = args.getList("intrinsics")) {
    const auto& v = *list;
    if (v.size() != 4 && v.size() != 9) {
      errors->push_back("--intrinsics takes fx,fy,cx,cy or fx,fy,cx,cy,k1,k2,p1,p2,k3");
    } else {
      s->camera.fx = v[0];
      s->camera.fy = v[1];
      s->camera.cx = v[2];
      s->camera.cy = v[3];
      if (v.size() == 9) std::copy(v.begin() + 4, v.end(), s->camera.distortion.begin());
      s->camera_source += " + --intrinsics";
    }
  }
  if (auto scale = args.getDouble("depth-scale")) {
    if (*scale <= 0) errors->push_back("--depth-scale must be > 0");
    s->camera.depth_scale = *scale;
  }
}

}  // namespace

OdometrySetup loadOdometrySetup(cli::Args& args, const std::string& dataset_dir,
                                std::vector<std::string>* errors) {
  OdometrySetup s;
  if (!dataset_dir.empty()) {
    const auto cam = readDatasetCamera(dataset_dir);
    if (!cam) {
      errors->push_back(cam.error());
    } else if (cam->has_value()) {
      s.camera = **cam;
      s.camera_source = dataset_dir + "/camera.yaml";
    }
  }
  ConfigReader reader;
  if (auto path = args.get("config")) {
    auto loaded = ConfigReader::fromFile(*path);
    if (!loaded) {
      errors->push_back(loaded.error());
    } else {
      reader = std::move(*loaded);
      if (reader.has("camera")) s.camera_source = *path;
    }
  }
  readCameraConfig(reader, "camera.", &s.camera);
  readOdometryConfig(reader, &s.odometry);
  reader.read("dataset.max_time_diff", &s.dataset.max_time_diff, 0.0, 10.0);
  for (const auto& e : reader.errors()) errors->push_back(e);
  applyOverrides(args, &s, errors);
  const std::string cam_err = s.camera.validate();
  if (!cam_err.empty()) errors->push_back("camera: " + cam_err);
  s.dataset.depth_scale = s.camera.depth_scale;
  s.dataset.expected_width = s.camera.width;
  s.dataset.expected_height = s.camera.height;
  s.effective = reader.effectiveValues();
  return s;
}

void applyLogLevel(cli::Args& args, std::vector<std::string>* errors) {
  if (auto name = args.get("log-level")) {
    log::Level level;
    if (log::parseLevel(*name, &level))
      log::setLevel(level);
    else
      errors->push_back("--log-level: unknown level '" + *name + "'");
  }
}

std::vector<std::string> datasetOptionNames() { return {"config", "intrinsics", "depth-scale", "log-level"}; }

const char* datasetOptionsHelp() {
  return "  --config FILE           YAML configuration (see deploy/config/odometry.yaml)\n"
         "  --intrinsics fx,fy,cx,cy[,k1,k2,p1,p2,k3]  camera override (default: dataset camera.yaml, else\n"
         "                          TUM freiburg1 517.3,516.5,318.6,255.3 with its distortion)\n"
         "  --depth-scale S         depth units per metre (TUM 5000, Kinect millimetres 1000)\n"
         "  --log-level L           debug|info|warn|error (default info)\n";
}

}  // namespace rgbdmap::app
