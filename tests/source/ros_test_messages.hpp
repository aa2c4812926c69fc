#pragma once
// The sensor_msgs content the test recordings carry (ROS 1 bags and ROS 2 MCAP files alike): camera_info
// of a camera, depth in a message encoding from a folder's raw units. Test-only.
#include <cmath>
#include <string>

#include <opencv2/core.hpp>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/source/ros_messages.hpp"

namespace rgbdmap::testing {

/// A TUM folder read with `camera`'s depth scale and image size, as the recordings are written from.
inline Result<TumDataset> openTestDataset(const std::string& dir, const CameraIntrinsics& camera) {
  DatasetOptions d;
  d.depth_scale = camera.depth_scale;
  d.expected_width = camera.width;
  d.expected_height = camera.height;
  return TumDataset::open(dir, d);
}

inline ros1::CameraInfo cameraInfoFor(const CameraIntrinsics& k, double stamp) {
  ros1::CameraInfo c;
  c.header = ros1::imageFromMat(cv::Mat(1, 1, CV_8UC1), "mono8", stamp).header;
  c.width = static_cast<uint32_t>(k.width);
  c.height = static_cast<uint32_t>(k.height);
  c.distortion_model = "plumb_bob";
  c.D.assign(k.distortion.begin(), k.distortion.end());
  c.K = {k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1};
  c.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.P = {k.fx, 0, k.cx, 0, 0, k.fy, k.cy, 0, 0, 0, 1, 0};
  return c;
}

/// Depth in a message encoding from the folder's raw units: 16UC1 millimetres (rounded), else 32FC1
/// metres with NaN for no measurement, as the TUM bags have it.
inline cv::Mat depthAsEncoding(const cv::Mat& raw, double depth_scale, const std::string& encoding) {
  cv::Mat out;
  if (encoding == "16UC1") {
    raw.convertTo(out, CV_16UC1, 1000.0 / depth_scale);
  } else {
    raw.convertTo(out, CV_32FC1, 1.0 / depth_scale);
    out.setTo(std::nanf(""), raw == 0);
  }
  return out;
}

}  // namespace rgbdmap::testing
