#pragma once
// The residuals of keyframe bundle adjustment, with analytic Jacobians.
//
// A keyframe pose is a 7-vector [qx qy qz qw tx ty tz] holding T_kf_map (p_kf = R * p_map + t). Its
// manifold (BaPoseManifold) perturbs on the left, T_kf_map <- exp(delta) * T_kf_map, delta = (rho, omega)
// in se3::exp's order. The cost functions write d r / d delta into the first 6 of the 7 ambient columns
// and 0 into the last; the manifold's PlusJacobian is [I6; 0], so Ceres' product gives the exact tangent
// Jacobian (tested against numeric differences through Plus).
//
// Rolling shutter: a keyframe also has a 3-vector w (radians), the rotation of the camera (in its own frame)
// during the image readout. A keypoint on the sensor row at fraction r of the image height from the middle
// row (r in [-0.5, 0.5]) was exposed when the camera had turned by r w since the middle row, so it saw the
// point at p_rs = p - r (w x p) (first order). Only the product of readout time and angular velocity is
// observable, so w needs neither: it is estimated per keyframe (a global-shutter camera gives w ~ 0).
//
// An observation of a landmark p_map by a keyframe: its undistorted keypoint (u, v) at pyramid octave o, its
// row fraction r, and, with depth, the measured depth d. Residuals, whitened:
//   (fx x/z + cx - u) / s,  (fy y/z + cy - v) / s           s = pixel_sigma * scale_factor^o
//   (1/z - 1/d) / s_inv                                      s_inv: inverse-depth sigma in 1/m
// with (x, y, z) = p_rs. The inverse-depth residual has a constant sigma for a structured-light sensor
// whose depth noise grows with z^2 (Kinect class: sigma_z = k z^2 gives sigma_1/z = k); ORB-SLAM's
// "virtual right camera" coordinate u - bf/z is the same measurement scaled by bf.
#include <ceres/manifold.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// Pinhole intrinsics of the ideal (undistorted) image.
struct BaIntrinsics {
  double fx = 517.3, fy = 516.5, cx = 318.6, cy = 255.3;
};

/// 7-vector <-> T_kf_map.
void poseToParams(const SE3& T_kf_map, double* params);
SE3 paramsToPose(const double* params);

/// The point as the keypoint's row saw it: p - r (w x p) (first order in r w).
Vec3 rollingShutterPoint(const Vec3& p_kf, const Vec3& w, double row_fraction);

class BaPoseManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

/// One observation's measurement.
struct BaMeasurement {
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< undistorted keypoint
  double sigma_px = 1.0;
  double row_fraction = 0.0;  ///< sensor row from the image middle, fraction of the height
  double depth_m = 0.0;       ///< 0: no depth (2 residuals)
  double inverse_depth_sigma = 0.025;
};

/// One observation's whitened residual rows by the pose's left perturbation (6), the point (3) and the
/// rolling-shutter rotation w (3).
template <int kRows>
struct ObservationJacobians {
  Eigen::Matrix<double, kRows, 6> pose;
  Eigen::Matrix<double, kRows, 3> point, w;
};

/// The residual (kRows values) of an observation of p_map by the keyframe T_kf_map = [R | t] and, when
/// `jacobians` is given, its Jacobians. False when the point is (nearly) behind the camera. Shared by the
/// Ceres cost functions and the own Schur solver (bundle_adjuster.cpp).
template <int kRows>
bool observationJacobians(const BaIntrinsics& k, const BaMeasurement& m, const Mat3& R, const Vec3& t,
                          const Vec3& p_map, const Vec3& w, double* residual,
                          ObservationJacobians<kRows>* jacobians);

/// Reprojection (2 residuals) or reprojection + inverse depth (3). Parameter blocks: pose (7), point (3),
/// rolling-shutter rotation w (3).
template <int kRows>
class ObservationCost final : public ceres::SizedCostFunction<kRows, 7, 3, 3> {
 public:
  ObservationCost(const BaIntrinsics& k, const BaMeasurement& m) : k_(k), m_(m) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  BaIntrinsics k_;
  BaMeasurement m_;
};
using ReprojectionCost = ObservationCost<2>;
using ReprojectionDepthCost = ObservationCost<3>;

/// The rolling-shutter rotation's prior: (w - mean) / sigma (3 rows), so that a frame with few observations
/// keeps w near what its motion predicts (predictedRollingShutter; 0 for a global shutter). Parameter block:
/// w (3).
class RollingShutterPrior final : public ceres::SizedCostFunction<3, 3> {
 public:
  RollingShutterPrior(double sigma_rad, const Vec3& mean) : inv_sigma_(1.0 / sigma_rad), mean_(mean) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  double inv_sigma_;
  Vec3 mean_;
};

/// The whitened residual of one observation without Jacobians (for outlier tests): 2 or 3 rows, or
/// nothing when the point is behind the camera (z <= 1e-3).
struct ObservationResidual {
  bool in_front = false;
  int rows = 0;
  double chi2 = 0.0;
  Eigen::Vector2d reprojection_px = Eigen::Vector2d::Zero();  ///< projection - keypoint, unwhitened
};
ObservationResidual observationResidual(const BaIntrinsics& k, const SE3& T_kf_map, const Vec3& p_map,
                                        const Vec3& w, const BaMeasurement& m);

}  // namespace rgbdmap
