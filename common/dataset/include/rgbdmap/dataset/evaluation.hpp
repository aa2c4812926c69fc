#pragma once
// Trajectory accuracy with the TUM RGB-D benchmark's conventions (Sturm et al., IROS 2012):
// ATE as evaluate_ate.py (timestamp association, Horn/Umeyama alignment, error of aligned positions) and
// RPE over a fixed time delta, E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) with Q ground truth and P the estimate.
// Differences from evaluate_rpe.py --fixed_delta: the script writes E as (P_j^-1 P_i)^-1 (Q_j^-1 Q_i) (same
// angle, translation in another frame), looks ground truth up by nearest stamp within 2x its median period
// rather than by one-to-one association, and subsamples to 10000 random pairs; here E follows the paper
// and every pair is used.
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/common/alignment.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/dataset/association.hpp"
#include "rgbdmap/dataset/trajectory.hpp"

namespace rgbdmap {

/// Summary of a list of non-negative errors. median as numpy (mean of the two middle values for even n),
/// std is the population standard deviation (numpy default). All zero for an empty list.
struct ErrorStats {
  size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
};
ErrorStats summarize(std::vector<double> errors);

struct AteOptions {
  double max_dt = 0.02;     ///< association tolerance, seconds (evaluate_ate.py --max_difference)
  bool with_scale = false;  ///< Sim(3) alignment (monocular); the default is rigid, as the benchmark
  /// Set: this alignment (and fixed_scale) is applied as it is instead of the least-squares one, e.g. the
  /// alignment of an earlier session's estimate in the same map frame (rgbdmap eval --align-on).
  std::optional<SE3> fixed_alignment;
  double fixed_scale = 1.0;
};

struct AteResult {
  size_t matched = 0;                                                ///< associated pose pairs
  double rmse = 0, mean = 0, median = 0, std = 0, max = 0, min = 0;  ///< metres, after alignment
  SE3 T_gt_est = SE3::Identity();  ///< aligns the estimate onto the ground truth
  double scale = 1.0;              ///< 1 unless AteOptions::with_scale
  bool alignment_unique = true;    ///< false when the matched positions are collinear (ATE still valid)
};

/// Fails on non-finite input, a bad option, or fewer than 3 associated poses.
Result<AteResult> computeAte(const Trajectory& gt, const Trajectory& est, const AteOptions& options = {});

struct RpeOptions {
  double delta = 1.0;    ///< seconds between the two poses of a pair
  double max_dt = 0.02;  ///< estimate <-> ground truth association tolerance, seconds
  /// A pair whose spacing differs from delta by more than this is skipped (seconds). Negative (default):
  /// the larger of max_dt and half the median spacing of the associated estimated poses, which keeps the
  /// closest partner inside a regular (jittery) stream and drops pairs that would run past its end.
  double max_delta_error = -1.0;
};

struct RpeResult {
  size_t pairs = 0;
  double delta_s = 1.0;
  double trans_rmse = 0, trans_mean = 0, trans_median = 0, trans_std = 0, trans_min = 0,
         trans_max = 0;  ///< m
  double rot_rmse_deg = 0, rot_mean_deg = 0, rot_median_deg = 0, rot_std_deg = 0, rot_min_deg = 0,
         rot_max_deg = 0;
};

/// Estimated poses are associated with ground truth (max_dt); for each associated pose i, j is the
/// associated pose whose time is closest to t_i + delta. Fails on non-finite input or when no pair exists.
Result<RpeResult> computeRpe(const Trajectory& gt, const Trajectory& est, const RpeOptions& options = {});

/// "ate_matched 250\nate_rmse_m 0.0123\n..." one `key value` per line.
std::string formatAte(const AteResult& ate);
/// "rpe_pairs 220\nrpe_trans_rmse_m ...\nrpe_rot_rmse_deg ...\n"
std::string formatRpe(const RpeResult& rpe);

}  // namespace rgbdmap
