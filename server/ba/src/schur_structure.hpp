#pragma once
// The layout of one own-solver solve: which frames and points are unknowns, the observations grouped by
// point, and the pose priors between frames in the problem. Shared by the parts of the Schur solver.
#include <vector>

#include <Eigen/StdVector>

#include "schur_bundle.hpp"

namespace rgbdmap::ba_detail {

constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;

// Products of fixed-size blocks are written as lazyProduct: above 20 rows + columns + depth (a 9x3 by 3x9
// product) Eigen would take its general matrix-matrix path, several times slower at these sizes.
template <typename T>
using AlignedVector = std::vector<T, Eigen::aligned_allocator<T>>;

/// Levenberg-Marquardt's damping of a block: its diagonal, clamped as Ceres clamps it.
template <int N>
Eigen::Matrix<double, N, 1> dampingOf(const Eigen::Matrix<double, N, N>& H) {
  return H.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
}

/// A keyframe during the solve.
struct FrameState {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
  Vec3 w = Vec3::Zero();
};

/// A pose prior between frames in the problem; one whose two frames are both free adds a block (a, b).
struct PriorTerm {
  const BaPosePrior* prior;
  int a, b;        ///< frame unknowns of its poses (-1: held)
  int block = -1;  ///< the (max, min) block when both are free and the reduced system is formed
};

struct SchurStructure {
  int nf = 0, np = 0;
  int nv = 0;          ///< frame unknowns
  int npv = 0;         ///< point unknowns
  int free_poses = 0;  ///< frames whose pose is an unknown
  std::vector<int> obs;                                        ///< the observations taking part
  std::vector<char> in_problem, pose_free, w_var, has_prior;  ///< per frame
  std::vector<int> frame_var, var_frame;  ///< frame -> its unknown (-1: none); unknown -> frame
  std::vector<int> point_var, var_point;  ///< point -> its unknown (-1: none); unknown -> point
  /// Per point unknown j, in [var_start[j], var_start[j + 1]): its observations by a frame unknown
  /// (positions in `obs`) and that unknown.
  std::vector<int> var_start, var_obs, var_of;
  size_t max_track = 0;  ///< the most observations by a frame unknown of one point
  std::vector<PriorTerm> priors;
};

/// The structure of a solve over the observations `active` marks; `estimate_w`: the rolling-shutter
/// rotations of frames with a prior are unknowns. Stops after the frames when no pose is free.
SchurStructure buildSchurStructure(const BaProblem& p, const BaSolveConfig& c, const std::vector<char>& active,
                                   bool estimate_w);

/// The normal equations' blocks at one linearisation point.
template <int D>
struct Linearisation {
  using MatD = Eigen::Matrix<double, D, D>;
  using VecD = Eigen::Matrix<double, D, 1>;
  using MatD3 = Eigen::Matrix<double, D, 3>;
  using Mat66 = Eigen::Matrix<double, 6, 6>;
  explicit Linearisation(const SchurStructure& s)
      : U(s.nv), g_frame(s.nv), V(s.npv), g_point(s.npv), W(s.obs.size()), prior_cross(s.priors.size()) {}
  AlignedVector<MatD> U;       ///< per frame unknown
  AlignedVector<VecD> g_frame;  ///< per frame unknown
  std::vector<Mat3> V;          ///< per point unknown
  std::vector<Vec3> g_point;    ///< per point unknown
  AlignedVector<MatD3> W;       ///< per observation (position in `obs`) by a frame unknown
  AlignedVector<Mat66> prior_cross;  ///< J_hi^T J_lo per prior between two free frames
};

}  // namespace rgbdmap::ba_detail
