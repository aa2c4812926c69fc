#pragma once
// Pinhole camera with optional radial-tangential (Brown-Conrady, OpenCV order k1 k2 p1 p2 k3) distortion.
#include <array>
#include <optional>
#include <string>

#include <Eigen/Core>

namespace rgbdmap {

struct CameraIntrinsics {
  double fx = 517.3;  ///< TUM freiburg1 calibration (the documented default).
  double fy = 516.5;
  double cx = 318.6;
  double cy = 255.3;
  int width = 640;
  int height = 480;
  /// Distortion k1 k2 p1 p2 k3. All zero means an ideal pinhole.
  std::array<double, 5> distortion{0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  /// Depth image value to metres: metres = value / depth_scale (TUM: 5000, Kinect mm: 1000).
  double depth_scale = 5000.0;
  /// The colour image's rolling-shutter readout: seconds from its first row to its last; 0 = a global
  /// shutter. The server's bundle adjustment expects each keyframe to turn by this time x the camera's
  /// angular velocity while the image is read out. 0.025 fits TUM freiburg1 (Kinect v1); most RGB-D colour
  /// cameras (Kinect, Xtion, Azure Kinect, RealSense D415/D435) are rolling shutter, 15-35 ms at 30 Hz.
  double readout_s = 0.025;

  /// Checks ranges; returns an empty string when valid, else the reason.
  std::string validate() const;
  bool hasDistortion() const;
};

/// Exactly the same calibration: every field equal (a robot that announces another camera is a new camera).
bool sameIntrinsics(const CameraIntrinsics& a, const CameraIntrinsics& b);

/// Projection and back-projection. Keypoints are in raw (distorted) pixels; undistort() maps them to
/// the ideal pinhole image so that back-projection with depth is exact.
class PinholeCamera {
 public:
  explicit PinholeCamera(const CameraIntrinsics& intrinsics);

  const CameraIntrinsics& intrinsics() const { return k_; }
  int width() const { return k_.width; }
  int height() const { return k_.height; }

  /// Project a point in camera coordinates into the ideal (undistorted) image. nullopt if z <= 0.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_cam) const;
  /// Project including lens distortion (raw image pixels).
  std::optional<Eigen::Vector2d> projectDistorted(const Eigen::Vector3d& p_cam) const;

  /// Map a raw pixel to its ideal pinhole pixel (iterative inverse of the distortion model).
  Eigen::Vector2d undistort(const Eigen::Vector2d& raw_px) const;
  /// Map an ideal pixel to raw pixel coordinates.
  Eigen::Vector2d distort(const Eigen::Vector2d& ideal_px) const;

  /// Back-project an ideal pixel with metric depth z into camera coordinates.
  Eigen::Vector3d backProject(const Eigen::Vector2d& ideal_px, double depth_m) const;
  /// Back-project a raw pixel (undistorts first).
  Eigen::Vector3d backProjectRaw(const Eigen::Vector2d& raw_px, double depth_m) const;

  bool inImage(const Eigen::Vector2d& px, double border = 0.0) const;

 private:
  Eigen::Vector2d distortNormalized(const Eigen::Vector2d& xn) const;
  CameraIntrinsics k_;
  bool distorted_;
};

}  // namespace rgbdmap
