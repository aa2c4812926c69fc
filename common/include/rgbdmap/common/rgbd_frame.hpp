#pragma once
// One RGB-D frame as read from a dataset or a camera: colour and depth registered to each other.
#include <cstdint>

#include <opencv2/core.hpp>

namespace rgbdmap {

struct RgbdFrame {
  double timestamp = 0.0;       ///< colour timestamp, seconds
  cv::Mat color;                ///< CV_8UC3, BGR (OpenCV order)
  cv::Mat depth;                ///< CV_16UC1, raw sensor units; 0 = no measurement
  double depth_scale = 5000.0;  ///< metres = depth / depth_scale

  /// Metric depth at integer pixel (x, y), 0 when missing or outside the image.
  double depthMetres(int x, int y) const {
    if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) return 0.0;
    return depth.at<uint16_t>(y, x) / depth_scale;
  }
};

}  // namespace rgbdmap
