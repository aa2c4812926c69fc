#include "rgbdmap/cli/odometry_setup.hpp"

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::app {

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
  return loadOdometrySetup(args, dataset_dir, errors, nullptr);
}

OdometrySetup loadOdometrySetup(cli::Args& args, const std::string& dataset_dir,
                                std::vector<std::string>* errors,
                                const std::function<void(ConfigReader&)>& read_more) {
  std::optional<CameraIntrinsics> camera;
  if (!dataset_dir.empty()) {
    const auto cam = readDatasetCamera(dataset_dir);
    if (!cam)
      errors->push_back(cam.error());
    else
      camera = *cam;
  }
  return loadOdometrySetup(args, camera, dataset_dir + "/camera.yaml", errors, read_more);
}

OdometrySetup loadOdometrySetup(cli::Args& args, const std::optional<CameraIntrinsics>& source_camera,
                                const std::string& camera_name, std::vector<std::string>* errors,
                                const std::function<void(ConfigReader&)>& read_more) {
  OdometrySetup s;
  if (source_camera) {
    s.camera = *source_camera;
    s.camera_source = camera_name;
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
  readDatasetConfig(reader, &s.dataset);
  if (read_more) read_more(reader);
  for (const auto& e : reader.errors()) errors->push_back(e);
  applyOverrides(args, &s, errors);
  const std::string cam_err = s.camera.validate();
  if (!cam_err.empty()) errors->push_back("camera: " + cam_err);
  s.dataset.depth_scale = s.camera.depth_scale;
  s.dataset.expected_width = s.camera.width;
  s.dataset.expected_height = s.camera.height;
  s.effective = odometryFileValues(s.camera, s.dataset, s.odometry);
  return s;
}

std::vector<std::string> datasetOptionNames() { return {"config", "intrinsics", "depth-scale", "log-level"}; }

const char* datasetOptionsHelp() {
  return "  --config FILE           YAML configuration (see deploy/config/odometry.yaml)\n"
         "  --intrinsics fx,fy,cx,cy[,k1,k2,p1,p2,k3]  camera override (default: dataset camera.yaml, else\n"
         "                          TUM freiburg1 517.3,516.5,318.6,255.3 with its distortion)\n"
         "  --depth-scale S         depth units per metre (TUM 5000, Kinect millimetres 1000)\n"
         "  --log-level L           debug|info|warn|error (default info)\n"
         "exit status: 0 success (a missing, corrupt or wrong-size image is skipped with a warning and\n"
         "counted as unreadable), 1 bad data (no frame readable, malformed line in rgb.txt, depth.txt or\n"
         "groundtruth.txt, missing dataset) or run-time failure, 2 usage or configuration error\n";
}

}  // namespace rgbdmap::app
