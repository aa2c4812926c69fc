#include "rgbdmap/common/common_config_tables.hpp"

namespace rgbdmap {

const ConfigTable<CameraIntrinsics>& cameraConfigTable() {
  using C = CameraIntrinsics;
  using R = ConfigRange;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("fx", &C::fx, R::closed(1.0, 1e5), "focal length (px); default: TUM freiburg1 colour camera")
          .add("fy", &C::fy, R::closed(1.0, 1e5), "")
          .add("cx", &C::cx, R::closed(-1e5, 1e5), "principal point (px)")
          .add("cy", &C::cy, R::closed(-1e5, 1e5), "")
          .add("width", &C::width, R::closed(1, 16384), "image size (px)")
          .add("height", &C::height, R::closed(1, 16384), "")
          .add("distortion", &C::distortion, "k1 k2 p1 p2 k3 (OpenCV order); zeros = pinhole")
          .add("depth_scale", &C::depth_scale, R::closed(1e-6, 1e9),
               "depth image units per metre (TUM 5000, Kinect/RealSense millimetres 1000)")
          .add("readout_s", &C::readout_s, R::closed(0.0, 0.1),
               "colour rolling-shutter readout, first row to last (s); 0 = global shutter (TUM fr1 0.025)");
  return table;
}

const ConfigTable<CameraMount>& cameraMountConfigTable() {
  using C = CameraMount;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("xyz_m", &C::xyz_m,
               "camera position in the robot's base frame (x forward, y left, z up; metres, within 100 m)")
          .add("rpy_deg", &C::rpy_deg,
               "roll, pitch, yaw of the camera body (x along the optical axis, y left, z up) in the base "
               "frame, fixed axes; 0 0 0 = level, looking forward; pitch > 0 tilts it down");
  return table;
}

}  // namespace rgbdmap
