#pragma once
// SE(3) helpers on Eigen. Poses are Eigen::Isometry3d named by the frames they map between:
// T_world_cam maps a point from camera coordinates into world coordinates (p_world = T_world_cam * p_cam).
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rgbdmap {

using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using SE3 = Eigen::Isometry3d;

namespace se3 {

/// Skew-symmetric matrix [v]x such that [v]x * w = v.cross(w).
Mat3 hat(const Vec3& v);

/// SO(3) exponential map (Rodrigues), exact near zero.
Mat3 expSO3(const Vec3& omega);
/// SO(3) logarithm; returns the rotation vector (angle in [0, pi]).
Vec3 logSO3(const Mat3& R);

/// SE(3) exponential of a twist xi = (rho, omega): translation part first, rotation second.
SE3 exp(const Vec6& xi);
/// SE(3) logarithm, inverse of exp().
Vec6 log(const SE3& T);

/// Pose from translation and unit quaternion (normalised on the way in).
SE3 fromQuatTrans(const Eigen::Quaterniond& q, const Vec3& t);
/// Pose from TUM order: tx ty tz qx qy qz qw.
SE3 fromTum(double tx, double ty, double tz, double qx, double qy, double qz, double qw);
/// Unit quaternion of a pose's rotation, with w >= 0.
Eigen::Quaterniond quat(const SE3& T);

/// Geodesic interpolation: alpha = 0 gives a, alpha = 1 gives b (slerp + linear translation).
SE3 interpolate(const SE3& a, const SE3& b, double alpha);

/// Rotation angle of a pose in radians, in [0, pi].
double rotationAngle(const SE3& T);

/// True if every coefficient of the pose is finite and the rotation is orthonormal within tol.
bool isValid(const SE3& T, double tol = 1e-6);

/// Re-orthonormalise the rotation part (guards against drift after long compositions).
SE3 normalized(const SE3& T);

/// Euler angles (roll, pitch, yaw) = rotations about x, y, z applied as R = Rz * Ry * Rx.
Vec3 eulerRPY(const Mat3& R);

}  // namespace se3
}  // namespace rgbdmap
