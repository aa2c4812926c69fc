#pragma once
// The back-end's policy for the information (inverse covariance) of pose-graph edges: what robots and the
// loop detector report is used only when it is a valid information matrix, and always with an uncertainty
// floor.
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// The sigmas of the policy (MapServerConfig::edgeInformation(): server.default_odometry_sigma_m/_deg,
/// server.edge_sigma_floor_m/_deg).
struct EdgeInformationConfig {
  /// Uncertainty of an odometry edge whose keyframe carried no information matrix (1 sigma per axis).
  double default_odometry_sigma_m = 0.02;
  double default_odometry_sigma_deg = 1.0;
  /// Uncertainty added to every edge's covariance (1 sigma per axis); 0 and 0: the information as reported.
  double edge_sigma_floor_m = 0.01;
  double edge_sigma_floor_deg = 0.5;
};

/// Symmetric (to rounding), finite and positive definite.
bool isPositiveDefinite(const Mat6& m);

/// Adds an uncertainty floor to an edge's covariance: information' = (information^-1 + diag(st^2, sr^2))^-1.
/// Information from a refinement's Hessian assumes independent pixel errors and is far too confident
/// (sub-millimetre on a keyframe edge); with it, a few centimetres of real drift look like a 40-sigma outlier
/// and the robust loss and consistency check would throw the true loop away.
Mat6 withCovarianceFloor(const Mat6& information, double sigma_t, double sigma_r);

/// withCovarianceFloor with edge_sigma_floor_m/_deg (unchanged when both are 0).
Mat6 flooredInformation(const Mat6& information, const EdgeInformationConfig& config);

/// An odometry edge: the keyframe's information floored, or default_odometry_sigma_m/_deg when it carried
/// none (or an invalid one).
Mat6 odometryInformation(const Mat6& reported, const EdgeInformationConfig& config);

/// A loop edge: the detector's information floored when valid, as it is otherwise.
Mat6 loopInformation(const Mat6& reported, const EdgeInformationConfig& config);

}  // namespace rgbdmap
