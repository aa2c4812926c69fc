#pragma once
// Config tables (config_table.hpp) of the camera and its mount: keys, ranges, meanings.
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/common/config_table.hpp"

namespace rgbdmap {

/// fx, fy, cx, cy, width, height, distortion, depth_scale (the `camera:` section).
const ConfigTable<CameraIntrinsics>& cameraConfigTable();

/// xyz_m, rpy_deg: the camera's pose on the robot (camera_mount.hpp).
const ConfigTable<CameraMount>& cameraMountConfigTable();

}  // namespace rgbdmap
