#pragma once
// One bundle adjustment: keyframe poses and landmark positions refined against every observation, with
// Levenberg-Marquardt and the Schur complement over the landmarks (the own solver, or Ceres). Plain structs
// in and out: the caller (LandmarkMap) decides the window, which keyframes are held fixed, and what to do
// with the observations found to be outliers.
//
// Two solves, as ORB-SLAM's local BA: a first solve with a Huber loss, then observations whose whitened
// chi2 exceeds the 95 % quantile (2 or 3 dof) or that fall behind their camera are left out and a second
// solve without them refines the rest. Their indices are returned so that the tracks can drop them.
#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "rgbdmap/ba/ba_cost.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// Which solver minimises: the own Levenberg-Marquardt with the landmarks eliminated per point and fixed-size
/// blocks (src/schur_bundle.hpp; 3-6x faster), or Ceres (the reference; the same residuals and trust-region
/// rule, held to the same minimum by a test).
enum class BaSolver { kSchur, kCeres };

struct BaSolveConfig {
  BaSolver solver = BaSolver::kSchur;
  double pixel_sigma = 1.0;           ///< keypoint sigma at octave 0, px
  double scale_factor = 1.2;          ///< ORB pyramid scale: sigma grows by this per octave
  /// Sigma of 1/depth, 1/m (0.025: 2.5 cm at 1 m, 10 cm at 2 m; ORB-SLAM's 1 px / bf for fr1). Measured on
  /// fr1_xyz and fr1_rpy after the BA, the median |1/z - 1/d| is 0.005-0.010 with a heavy tail.
  double inverse_depth_sigma = 0.025;
  bool use_depth = true;              ///< the inverse-depth residual where a keypoint has depth
  /// Estimate each keyframe's rolling-shutter rotation w (ba_cost.hpp); false: w stays as given (0).
  bool rolling_shutter = true;
  /// Prior sigma of w (rad) around the centre its keyframe carries (LandmarkKeyframe::w_prior: the robot
  /// camera's readout time x its angular velocity, predictedRollingShutter in landmark_map.hpp; 0 for a
  /// global shutter). Centred on 0 the prior had to be loose (0.005) for fr1_rpy's turns, and then w traded
  /// with the translations (fr1_xyz's map 3.5 % short). Centred on the motion, 0.0025 maps fr1_rpy and
  /// fr1_xyz best among 0.00125-0.005 (docs/results.md).
  double rolling_shutter_sigma_rad = 0.0025;
  double chi2_2dof = 5.991;    ///< Huber threshold and outlier test, 2 rows (95 %)
  double chi2_3dof = 7.815;    ///< same, 3 rows
  int first_iterations = 5;    ///< Levenberg-Marquardt iterations before the outlier test
  int second_iterations = 10;  ///< after it; 0 skips the second solve
  /// Wall-clock limit of each solve; 0 = none. The iterations bound the work: a limit in seconds would
  /// make the map depend on the machine's load.
  double max_time_s = 0.0;
  /// The own solver's reduced camera system with at least this many frame unknowns (a global BA) is solved
  /// by conjugate gradients on the implicit Schur complement, preconditioned by its block diagonal, instead
  /// of a sparse Cholesky: no matrix and no factor to store, work and memory linear in the observations
  /// (which global_max_observations caps). A Cholesky factor fills in where keyframes revisit one scene, and
  /// its cost grows far faster than the keyframes (server/ba/README.md has the measurements).
  int iterative_min_frames = 100;
  int iterative_max_steps = 100;      ///< conjugate-gradient steps per Levenberg-Marquardt iteration
  double iterative_tolerance = 0.01;  ///< ... until the residual is this fraction of the right-hand side
  int num_threads = 1;                ///< Ceres threads (the own solver uses one)
};

struct BaFrame {
  int64_t id = 0;
  BaIntrinsics camera;
  SE3 T_kf_map = SE3::Identity();
  bool fixed = false;
  Vec3 w = Vec3::Zero();        ///< rolling-shutter rotation over the readout (rad)
  bool fixed_w = false;         ///< w held (a fixed frame's, usually)
  Vec3 w_prior = Vec3::Zero();  ///< the centre of w's prior: the rotation the camera's motion predicts
};

struct BaPoint {
  int64_t id = 0;
  Vec3 p_map = Vec3::Zero();
};

struct BaObservation {
  int frame = 0;                                 ///< index into BaProblem::frames
  int point = 0;                                 ///< index into BaProblem::points
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  ///< undistorted keypoint
  int octave = 0;
  double depth_m = 0.0;       ///< 0: no depth
  double row_fraction = 0.0;  ///< the keypoint's sensor row from the middle, fraction of the height
};

/// A relative-pose prior between two frames: a pose-graph edge that no landmark of the adjustment covers
/// (an odometry step into a room not seen before). Residual S * log(T_a_b^-1 * T_map_a^-1 * T_map_b), tangent
/// order (rho, omega), as the pose graph's (pose_graph_residual.hpp): S is the upper Cholesky factor of the
/// information in the residual's frame. Only frames with observations in the problem take part.
struct BaPosePrior {
  int frame_a = 0, frame_b = 0;  ///< indices into BaProblem::frames
  SE3 T_a_b = SE3::Identity();   ///< measured pose of b in a
  Mat6 sqrt_information = Mat6::Identity();
};

struct BaProblem {
  std::vector<BaFrame> frames;
  std::vector<BaPoint> points;
  std::vector<BaObservation> observations;
  std::vector<BaPosePrior> priors;
};

/// The prior's whitened residual at frame poses T_a_map, T_b_map (the solvers' T_kf_map).
Vec6 posePriorResidual(const BaPosePrior& prior, const SE3& T_a_map, const SE3& T_b_map);

struct BaReport {
  int frames = 0, fixed_frames = 0, points = 0, observations = 0;
  int iterations = 0;
  int linear_steps = 0;  ///< conjugate-gradient steps of the own solver's iterative path (0: factorised)
  double initial_cost = 0.0, final_cost = 0.0;  ///< Ceres cost (0.5 * robust sum) of the first / last solve
  double initial_rms_px = 0.0, final_rms_px = 0.0;  ///< reprojection RMS over the inliers, octave-0 px
  double time_ms = 0.0;
  bool cancelled = false;
  /// A solve hit its wall-clock limit. When the first did, no observation was rejected and the second
  /// solve did not run (an unconverged state would reject good observations).
  bool out_of_time = false;
  /// The last solve used all of its iterations: stopped by the budget, not converged.
  bool at_iteration_cap = false;
};

struct BaSolution {
  std::vector<SE3> T_kf_map;  ///< per frame (fixed frames unchanged)
  std::vector<Vec3> w;        ///< per frame, rolling-shutter rotation
  std::vector<Vec3> p_map;    ///< per point
  std::vector<int> outliers;  ///< indices into observations
  BaReport report;
};

/// Solves the problem. Fails on an empty problem, indices out of range, non-finite input or no free frame.
/// `cancel` (optional) stops the running solve; the best estimate so far is returned with cancelled set.
Result<BaSolution> solveBundle(const BaProblem& problem, const BaSolveConfig& config,
                               const std::atomic<bool>* cancel = nullptr);

}  // namespace rgbdmap
