#pragma once
// The two ROS 1 messages an RGB-D bag holds, in their serialised form (little-endian, as rosbag stores
// them): sensor_msgs/Image and sensor_msgs/CameraInfo. Decoding checks every length against the bytes there
// are (a bag is untrusted input); encoding exists for the tests and the bag writer that make test bags.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"

namespace rgbdmap::ros1 {

inline constexpr const char* kImageType = "sensor_msgs/Image";
inline constexpr const char* kImageMd5 = "060021388200f6f0f447d0fcd9c64743";
inline constexpr const char* kCameraInfoType = "sensor_msgs/CameraInfo";
inline constexpr const char* kCameraInfoMd5 = "c9a58c1b0b154e0e6da7578cb991d214";

struct Header {
  uint32_t seq = 0;
  uint32_t stamp_sec = 0, stamp_nsec = 0;
  std::string frame_id;
  double stamp() const { return stamp_sec + stamp_nsec * 1e-9; }
};

struct Image {
  Header header;
  uint32_t height = 0, width = 0;
  std::string encoding;  ///< rgb8, bgr8, mono8, 32FC1, 16UC1, ...
  uint8_t is_bigendian = 0;
  uint32_t step = 0;  ///< bytes per row
  std::vector<uint8_t> data;
};

struct CameraInfo {
  Header header;
  uint32_t height = 0, width = 0;
  std::string distortion_model;  ///< plumb_bob: D = k1, k2, p1, p2, k3
  std::vector<double> D;
  std::array<double, 9> K{};
  std::array<double, 9> R{};
  std::array<double, 12> P{};
};

Result<Image> decodeImage(const uint8_t* bytes, size_t size);
Result<CameraInfo> decodeCameraInfo(const uint8_t* bytes, size_t size);
std::vector<uint8_t> encodeImage(const Image& image);
std::vector<uint8_t> encodeCameraInfo(const CameraInfo& info);

/// Colour as CV_8UC3 BGR from rgb8, bgr8 or mono8; the reason otherwise (size, encoding, step).
Result<cv::Mat> colorFromImage(const Image& image);
/// Depth as CV_16UC1 with `*depth_scale` raw units per metre: 32FC1 metres -> 5000 (0.2 mm; NaN, inf,
/// <= 0 and beyond 13.1 m -> 0 = no measurement), 16UC1 millimetres -> 1000 (copied).
Result<cv::Mat> depthFromImage(const Image& image, double* depth_scale);
/// The camera a CameraInfo describes (K and, for plumb_bob, D); depth_scale is left to the caller.
Result<CameraIntrinsics> cameraFromInfo(const CameraInfo& info);

/// Image messages from OpenCV matrices (tests, writers): BGR CV_8UC3 as "rgb8" or "bgr8", CV_8UC1 as
/// "mono8", CV_32FC1 as "32FC1", CV_16UC1 as "16UC1".
Image imageFromMat(const cv::Mat& mat, const std::string& encoding, double stamp);

}  // namespace rgbdmap::ros1
