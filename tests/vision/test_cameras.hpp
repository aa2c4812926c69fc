#pragma once
// Cameras shared by the client tests.
#include "rgbdmap/common/camera.hpp"

namespace rgbdmap::testing {

/// The ROS default Kinect camera: 640x480, fx = fy = 525, no distortion.
inline CameraIntrinsics idealPinhole() {
  CameraIntrinsics k;
  k.fx = k.fy = 525;
  k.cx = 319.5;
  k.cy = 239.5;
  k.distortion = {0, 0, 0, 0, 0};
  return k;
}

}  // namespace rgbdmap::testing
