#pragma once
// What a dataset-reading command needs, assembled once from (lowest to highest priority): built-in
// defaults (TUM fr1), the dataset's camera.yaml, the --config YAML file, and command-line overrides.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/client/odometry_config_io.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/config_reader.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"

namespace rgbdmap::app {

struct OdometrySetup {
  CameraIntrinsics camera;
  OdometryConfig odometry;
  DatasetOptions dataset;
  std::string camera_source = "defaults (TUM freiburg1)";
  std::vector<ConfigValue> effective;  ///< the camera:, dataset: and odometry: values in effect
};

/// Builds the setup for `dataset_dir` from --config, --intrinsics and --depth-scale in `args`.
/// All problems are appended to *errors.
OdometrySetup loadOdometrySetup(cli::Args& args, const std::string& dataset_dir,
                                std::vector<std::string>* errors);

/// The same, for programs whose --config file has sections of their own: `read_more` reads them from the
/// configuration before its errors (unknown keys included) are collected.
OdometrySetup loadOdometrySetup(cli::Args& args, const std::string& dataset_dir,
                                std::vector<std::string>* errors,
                                const std::function<void(ConfigReader&)>& read_more);

/// The same with the camera a frame source carries (camera_info of a bag, a device) in place of a dataset's
/// camera.yaml (`camera_name` says where it came from, for the log).
OdometrySetup loadOdometrySetup(cli::Args& args, const std::optional<CameraIntrinsics>& source_camera,
                                const std::string& camera_name, std::vector<std::string>* errors,
                                const std::function<void(ConfigReader&)>& read_more);


/// Options every dataset command accepts, for Args::checkAllowed.
std::vector<std::string> datasetOptionNames();
const char* datasetOptionsHelp();

}  // namespace rgbdmap::app
