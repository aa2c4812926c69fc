#include "rgbdmap/dataset/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"

namespace rgbdmap {
namespace {

constexpr double kRadToDeg = 180.0 / EIGEN_PI;
/// Rotation matrices from parsed or composed poses are orthonormal far better than this.
constexpr double kRotationTolerance = 1e-4;

/// Rejects non-finite timestamps and non-finite or non-rotation poses, naming the first bad one.
Status checkTrajectory(const Trajectory& t, const char* name) {
  if (t.empty()) return Status::failure(std::string(name) + " trajectory is empty");
  for (size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i].timestamp))
      return Status::failure(std::string(name) + " pose " + std::to_string(i) + ": non-finite timestamp");
    if (!se3::isValid(t[i].T_world_cam, kRotationTolerance))
      return Status::failure(std::string(name) + " pose " + std::to_string(i) +
                             " (t=" + std::to_string(t[i].timestamp) + "): non-finite or non-rotation pose");
  }
  return Status::success();
}

Status checkInputs(const Trajectory& gt, const Trajectory& est, double max_dt) {
  if (!(std::isfinite(max_dt) && max_dt > 0)) return Status::failure("max_dt must be finite and > 0");
  Status s = checkTrajectory(gt, "ground-truth");
  return s ? checkTrajectory(est, "estimated") : s;
}

std::vector<double> timestamps(const Trajectory& t) {
  std::vector<double> out;
  out.reserve(t.size());
  for (const auto& p : t) out.push_back(p.timestamp);
  return out;
}

/// Associated (estimate, ground truth) pose pairs, sorted by estimate time.
struct MatchedPoses {
  std::vector<double> t;
  std::vector<SE3> est, gt;
};

MatchedPoses matchPoses(const Trajectory& gt, const Trajectory& est, double max_dt) {
  MatchedPoses m;
  for (const IndexPair& p : associate(timestamps(est), timestamps(gt), max_dt)) {
    m.t.push_back(est[p.a].timestamp);
    m.est.push_back(est[p.a].T_world_cam);
    m.gt.push_back(gt[p.b].T_world_cam);
  }
  return m;
}

/// Index in sorted `t` of the value closest to `target` (the earlier one on a tie).
size_t closestIndex(const std::vector<double>& t, double target) {
  const auto it = std::lower_bound(t.begin(), t.end(), target);
  if (it == t.begin()) return 0;
  if (it == t.end()) return t.size() - 1;
  const size_t hi = static_cast<size_t>(it - t.begin());
  return (t[hi] - target < target - t[hi - 1]) ? hi : hi - 1;
}

/// Half the median spacing of sorted timestamps (plus a little slack for rounding); 0 with fewer than 2.
double halfMedianSpacing(const std::vector<double>& t) {
  if (t.size() < 2) return 0.0;
  std::vector<double> gaps;
  for (size_t i = 1; i < t.size(); ++i) gaps.push_back(t[i] - t[i - 1]);
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return 0.5 * gaps[gaps.size() / 2] + 1e-9;
}

}  // namespace

ErrorStats summarize(std::vector<double> errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  std::sort(errors.begin(), errors.end());
  const double n = static_cast<double>(errors.size());
  double sum = 0, sum_sq = 0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  s.std = std::sqrt(std::max(0.0, sum_sq / n - s.mean * s.mean));
  const size_t mid = errors.size() / 2;
  s.median = errors.size() % 2 ? errors[mid] : 0.5 * (errors[mid - 1] + errors[mid]);
  s.min = errors.front();
  s.max = errors.back();
  return s;
}

Result<AteResult> computeAte(const Trajectory& gt, const Trajectory& est, const AteOptions& options) {
  using R = Result<AteResult>;
  const Status input = checkInputs(gt, est, options.max_dt);
  if (!input) return R::failure("ATE: " + input.error());
  const MatchedPoses m = matchPoses(gt, est, options.max_dt);
  if (m.t.size() < 3)
    return R::failure("ATE: only " + std::to_string(m.t.size()) +
                      " estimated poses have ground truth within " + formatShort(options.max_dt) +
                      " s (need 3; do the timestamps refer to the same clock?)");
  std::vector<Vec3> p_est, p_gt;
  for (size_t i = 0; i < m.t.size(); ++i) {
    p_est.push_back(m.est[i].translation());
    p_gt.push_back(m.gt[i].translation());
  }
  auto align = solveAlignment(p_est, p_gt, options.with_scale);
  if (!align) return R::failure("ATE: " + align.error());
  if (options.fixed_alignment) {
    align->T_gt_est = *options.fixed_alignment;
    align->scale = options.fixed_scale;
    align->unique = true;
  }
  if (!align->unique)
    log::warn("ATE: matched positions are collinear; the alignment's roll about them is arbitrary");

  std::vector<double> errors;
  const SE3& T = align->T_gt_est;
  for (size_t i = 0; i < p_est.size(); ++i)
    errors.push_back((align->scale * (T.linear() * p_est[i]) + T.translation() - p_gt[i]).norm());
  const ErrorStats s = summarize(errors);
  AteResult r;
  r.matched = s.count;
  r.rmse = s.rmse;
  r.mean = s.mean;
  r.median = s.median;
  r.std = s.std;
  r.max = s.max;
  r.min = s.min;
  r.T_gt_est = T;
  r.scale = align->scale;
  r.alignment_unique = align->unique;
  return r;
}

Result<RpeResult> computeRpe(const Trajectory& gt, const Trajectory& est, const RpeOptions& options) {
  using R = Result<RpeResult>;
  if (!(std::isfinite(options.delta) && options.delta > 0) || !std::isfinite(options.max_delta_error))
    return R::failure("RPE: delta must be finite and > 0, max_delta_error finite");
  const Status input = checkInputs(gt, est, options.max_dt);
  if (!input) return R::failure("RPE: " + input.error());
  const MatchedPoses m = matchPoses(gt, est, options.max_dt);
  const double tolerance = options.max_delta_error >= 0 ? options.max_delta_error
                                                        : std::max(options.max_dt, halfMedianSpacing(m.t));

  std::vector<double> trans, rot;
  for (size_t i = 0; i < m.t.size(); ++i) {
    const size_t j = closestIndex(m.t, m.t[i] + options.delta);
    if (j <= i || std::abs(m.t[j] - m.t[i] - options.delta) > tolerance) continue;
    const SE3 E = (m.gt[i].inverse() * m.gt[j]).inverse() * (m.est[i].inverse() * m.est[j]);
    trans.push_back(E.translation().norm());
    rot.push_back(se3::rotationAngle(E) * kRadToDeg);
  }
  if (trans.empty())
    return R::failure("RPE: no pair of associated poses " + formatShort(options.delta) + " s apart (" +
                      std::to_string(m.t.size()) + " estimated poses have ground truth)");
  const ErrorStats t = summarize(trans), a = summarize(rot);
  RpeResult r;
  r.pairs = t.count;
  r.delta_s = options.delta;
  r.trans_rmse = t.rmse;
  r.trans_mean = t.mean;
  r.trans_median = t.median;
  r.trans_std = t.std;
  r.trans_min = t.min;
  r.trans_max = t.max;
  r.rot_rmse_deg = a.rmse;
  r.rot_mean_deg = a.mean;
  r.rot_median_deg = a.median;
  r.rot_std_deg = a.std;
  r.rot_min_deg = a.min;
  r.rot_max_deg = a.max;
  return r;
}

}  // namespace rgbdmap
