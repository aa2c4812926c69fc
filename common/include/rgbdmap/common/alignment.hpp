#pragma once
// Least-squares alignment of two corresponding point sets (Horn 1987 / Umeyama 1991), as used by the TUM
// benchmark's evaluate_ate.py: find R, t (and optionally s) minimising sum |p_gt - (s R p_est + t)|^2.
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// p_gt = scale * (T_gt_est.rotation() * p_est) + T_gt_est.translation().
struct Alignment {
  SE3 T_gt_est = SE3::Identity();
  double scale = 1.0;
  /// False when the points are collinear: the rotation about their line is then arbitrary (but the residual
  /// is still the least-squares minimum).
  bool unique = true;
};

/// Solves the alignment for any number >= 1 of finite pairs, degenerate or not (see Alignment::unique).
/// Fails only for empty/mismatched/non-finite input, or with_scale and all est points coinciding.
Result<Alignment> solveAlignment(const std::vector<Vec3>& est, const std::vector<Vec3>& gt, bool with_scale);

/// Strict alignment: additionally fails for fewer than 3 pairs or collinear points (non-unique rotation).
Result<Alignment> alignUmeyama(const std::vector<Vec3>& est, const std::vector<Vec3>& gt,
                               bool with_scale = false);

/// Rigid (no scale) strict alignment; returns T_gt_est.
Result<SE3> alignRigid(const std::vector<Vec3>& est, const std::vector<Vec3>& gt);

}  // namespace rgbdmap
