#pragma once
// Residual of one relative-pose edge, templated for Ceres autodiff.
//
// Each node is one 7-double parameter block [qx qy qz qw tx ty tz] (Eigen quaternion memory order, then the
// translation) of T_map_kf, on ceres::ProductManifold<EigenQuaternionManifold, EuclideanManifold<3>>.
// The residual is r = L^T * log(T_from_to^-1 * T_map_from^-1 * T_map_to), tangent order (rho, omega), with
// the exact SE(3) logarithm (same as se3::log) and L^T the upper Cholesky factor of the residual-frame
// information (r^T r = whitened chi2). Autodiff is fast enough for the benchmark (see the README numbers).
#include <ceres/rotation.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// Information of the measurement given for a left perturbation (T_from_to = exp(d) * T_true, as the client's
/// Keyframe::information) mapped to the frame of the residual above: Ad(T_from_to)^T * info * Ad(T_from_to).
Mat6 residualInformation(const SE3& T_from_to, const Mat6& information_left);

/// Upper-triangular sqrt_information with sqrt^T * sqrt = information; false if not positive definite.
bool sqrtInformation(const Mat6& information, Mat6* sqrt_information);

class RelativePoseResidual {
 public:
  RelativePoseResidual(const SE3& T_from_to, const Mat6& sqrt_information)
      : q_to_from_(Eigen::Quaterniond(T_from_to.linear()).conjugate().normalized()),
        t_from_to_(T_from_to.translation()),
        sqrt_information_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* pose_from, const T* pose_to, T* residual) const {
    using Quat = Eigen::Quaternion<T>;
    using V3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Quat> q_map_from(pose_from);
    const Eigen::Map<const V3> t_map_from(pose_from + 4);
    const Eigen::Map<const Quat> q_map_to(pose_to);
    const Eigen::Map<const V3> t_map_to(pose_to + 4);
    // Estimated relative pose T_from_to_est = T_map_from^-1 * T_map_to.
    const Quat q_from_map = q_map_from.conjugate();
    const Quat q_rel = q_from_map * q_map_to;
    const V3 t_rel = q_from_map * (t_map_to - t_map_from);
    // Error E = T_from_to^-1 * T_from_to_est.
    const Quat q_meas_inv = q_to_from_.template cast<T>();
    const Quat q_err = q_meas_inv * q_rel;
    const V3 t_err = q_meas_inv * (t_rel - t_from_to_.template cast<T>());
    Eigen::Matrix<T, 6, 1> xi;
    const T q_wxyz[4] = {q_err.w(), q_err.x(), q_err.y(), q_err.z()};
    T omega[3];
    ceres::QuaternionToAngleAxis(q_wxyz, omega);
    const V3 w(omega[0], omega[1], omega[2]);
    xi.template head<3>() = leftJacobianInverseTimes(w, t_err);
    xi.template tail<3>() = w;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_information_.template cast<T>() * xi;
    return true;
  }

  /// J_l(omega)^-1 * v, with a series for small angles so the derivatives stay finite at zero.
  template <typename T>
  static Eigen::Matrix<T, 3, 1> leftJacobianInverseTimes(const Eigen::Matrix<T, 3, 1>& w,
                                                         const Eigen::Matrix<T, 3, 1>& v) {
    const T theta2 = w.squaredNorm();
    T coef;
    if (theta2 < T(1e-4)) {
      coef = T(1.0 / 12.0) + theta2 / T(720.0);
    } else {
      using std::cos;
      using std::sin;
      using std::sqrt;
      const T half = T(0.5) * sqrt(theta2);
      coef = (T(1.0) - half * cos(half) / sin(half)) / theta2;
    }
    const Eigen::Matrix<T, 3, 1> wxv = w.cross(v);
    return v - T(0.5) * wxv + coef * w.cross(wxv);
  }

 private:
  Eigen::Quaterniond q_to_from_;
  Vec3 t_from_to_;
  Mat6 sqrt_information_;
};

/// Packs T_map_kf into the 7-double parameter layout above, and back.
void packPose(const SE3& T_map_kf, double* pose7);
SE3 unpackPose(const double* pose7);

}  // namespace rgbdmap
