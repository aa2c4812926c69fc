#pragma once
// YAML sections for the camera and the odometry, read through their config tables (ranges checked, every
// error collected). Every key is optional; absent keys keep the struct defaults. The tables also document
// deploy/config/odometry.yaml (a test renders them and compares) and give the start-up log block.
#include <string>
#include <vector>

#include "rgbdmap/client/odometry_config.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/config_reader.hpp"
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"

namespace rgbdmap {

const ConfigTable<KeyframeConfig>& keyframeConfigTable();
/// Keys relative to the `odometry:` section (orb.n_features, window_keyframes, ...).
const ConfigTable<OdometryConfig>& odometryConfigTable();

/// Reads fx, fy, cx, cy, width, height, distortion [k1, k2, p1, p2, k3], depth_scale under `prefix`
/// (e.g. "camera.").
void readCameraConfig(ConfigReader& reader, const std::string& prefix, CameraIntrinsics* camera);

/// Reads the `odometry:` section (orb, matcher, guided, ransac, refine, keyframe and window keys).
void readOdometryConfig(ConfigReader& reader, OdometryConfig* config);

/// Reads the `dataset:` section (max_time_diff).
void readDatasetConfig(ConfigReader& reader, DatasetOptions* options);

/// The camera:, dataset: and odometry: sections with these values, as documented and logged.
std::vector<ConfigValue> odometryFileValues(const CameraIntrinsics& camera, const DatasetOptions& dataset,
                                            const OdometryConfig& odometry);
/// odometryFileValues of the defaults (what logConfiguration compares with).
std::vector<ConfigValue> defaultOdometryFileValues();

}  // namespace rgbdmap
