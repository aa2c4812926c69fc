#pragma once
// YAML sections for the camera and the odometry, read through ConfigReader (ranges checked, every error
// collected). Every key is optional; absent keys keep the struct defaults.
#include <string>

#include "rgbdmap/client/odometry_config.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/config_reader.hpp"

namespace rgbdmap {

/// Reads fx, fy, cx, cy, width, height, distortion [k1, k2, p1, p2, k3], depth_scale under `prefix`
/// (e.g. "camera.").
void readCameraConfig(ConfigReader& reader, const std::string& prefix, CameraIntrinsics* camera);

/// Reads the `odometry:` section (orb, matcher, guided, ransac, refine, keyframe and window keys).
void readOdometryConfig(ConfigReader& reader, OdometryConfig* config);

}  // namespace rgbdmap
