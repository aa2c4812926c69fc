#pragma once
// ORB features of one RGB-D frame, with metric depth and back-projected 3-D points.
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

struct FrameFeatures {
  std::vector<cv::KeyPoint> keypoints;  ///< raw (distorted) pixel coordinates
  cv::Mat descriptors;                  ///< N x 32, CV_8U
  std::vector<Eigen::Vector2d> px;      ///< undistorted (ideal pinhole) pixel of each keypoint
  std::vector<double> depth_m;          ///< metric depth, 0 where missing or out of range
  std::vector<Vec3> p_cam;              ///< 3-D point in the camera frame (valid where depth_m > 0)

  size_t size() const { return keypoints.size(); }
  bool hasDepth(size_t i) const { return depth_m[i] > 0.0; }
  size_t countWithDepth() const;
};

/// ORB extraction spread over the image by a grid: FAST corners are detected per pyramid level,
/// the strongest kept per cell, then described with ORB. Not thread-safe (owns a cv::ORB).
class OrbExtractor {
 public:
  explicit OrbExtractor(const OrbConfig& config);
  FrameFeatures extract(const RgbdFrame& frame, const PinholeCamera& camera) const;
  /// Grey image input (for tests and benchmarks that do not need depth).
  void detectAndDescribe(const cv::Mat& gray, std::vector<cv::KeyPoint>* keypoints,
                         cv::Mat* descriptors) const;

 private:
  std::vector<cv::KeyPoint> bucket(std::vector<cv::KeyPoint> keypoints, cv::Size size) const;
  OrbConfig config_;
  cv::Ptr<cv::ORB> orb_;
};

}  // namespace rgbdmap
