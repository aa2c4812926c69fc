#include "rgbdmap/dataset/trajectory_smoothing.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/QR>

namespace rgbdmap {
namespace {

/// The fitted values at t = 0 of a least-squares polynomial of degree <= 2 through (t_j, y_j) (rows of y),
/// the degree lowered until the design matrix has full rank. Times are scaled by `scale` for conditioning.
Eigen::VectorXd fitAtZero(const std::vector<double>& t, const Eigen::MatrixXd& y, double scale) {
  const int n = static_cast<int>(t.size());
  for (int degree = std::min(2, n - 1); degree > 0; --degree) {
    Eigen::MatrixXd A(n, degree + 1);
    for (int j = 0; j < n; ++j) {
      const double s = t[j] / scale;
      for (int k = 0; k <= degree; ++k) A(j, k) = std::pow(s, k);
    }
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
    if (qr.rank() == degree + 1) return qr.solve(y).row(0).transpose();
  }
  return y.colwise().mean().transpose();  // every time equal: the mean is the fit
}

/// The smoothed pose of poses[order[i]] from the usable poses order[begin, end) of its segment (in time
/// order) within +-half_window_s of it.
SE3 smoothOne(const Trajectory& poses, const std::vector<SmoothingInput>& inputs,
              const std::vector<size_t>& order, size_t i, size_t begin, size_t end, double half_window_s) {
  const StampedPose& p0 = poses[order[i]];
  const double t0 = p0.timestamp;
  const Mat3 R0 = p0.T_world_cam.linear();
  size_t lo = i, hi = i + 1;
  while (lo > begin && t0 - poses[order[lo - 1]].timestamp <= half_window_s) --lo;
  while (hi < end && poses[order[hi]].timestamp - t0 <= half_window_s) ++hi;
  std::vector<double> t;
  Eigen::MatrixXd y(static_cast<Eigen::Index>(hi - lo), 6);
  for (size_t k = lo; k < hi; ++k) {
    const StampedPose& p = poses[order[k]];
    if (!inputs[order[k]].usable) continue;
    const auto row = static_cast<Eigen::Index>(t.size());
    y.row(row).head<3>() = p.T_world_cam.translation().transpose();
    y.row(row).tail<3>() = se3::logSO3(R0.transpose() * p.T_world_cam.linear()).transpose();
    t.push_back(p.timestamp - t0);
  }
  if (t.size() < 2) return p0.T_world_cam;
  const Eigen::VectorXd v = fitAtZero(t, y.topRows(static_cast<Eigen::Index>(t.size())), half_window_s);
  SE3 out = SE3::Identity();
  out.linear() = R0 * se3::expSO3(v.tail<3>());
  out.translation() = v.head<3>();
  return se3::isValid(out, 1e-6) ? se3::normalized(out) : p0.T_world_cam;
}

/// `inputs` parallel to `poses` (another size: one segment, all usable) with every non-finite pose marked
/// unusable; nullopt when a stamp is not finite (there is no time order).
std::optional<std::vector<SmoothingInput>> checkedInputs(const Trajectory& poses,
                                                         const std::vector<SmoothingInput>& inputs_in) {
  std::vector<SmoothingInput> inputs =
      inputs_in.size() == poses.size() ? inputs_in : std::vector<SmoothingInput>(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    if (!std::isfinite(poses[i].timestamp)) return std::nullopt;
    if (!poses[i].T_world_cam.matrix().allFinite()) inputs[i].usable = false;
  }
  return inputs;
}

}  // namespace

Trajectory smoothTrajectory(const Trajectory& poses, const std::vector<SmoothingInput>& inputs_in,
                            double half_window_s) {
  if (!(half_window_s > 0.0) || poses.size() < 2) return poses;
  const std::optional<std::vector<SmoothingInput>> checked = checkedInputs(poses, inputs_in);
  if (!checked) return poses;
  const std::vector<SmoothingInput>& inputs = *checked;
  // Indices grouped by segment id, each group in time order.
  std::vector<size_t> order(poses.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (inputs[a].segment != inputs[b].segment) return inputs[a].segment < inputs[b].segment;
    return poses[a].timestamp < poses[b].timestamp;
  });
  Trajectory out = poses;
  for (size_t begin = 0; begin < order.size();) {
    size_t end = begin + 1;
    while (end < order.size() && inputs[order[end]].segment == inputs[order[begin]].segment) ++end;
    for (size_t i = begin; i < end; ++i)
      if (inputs[order[i]].usable)
        out[order[i]].T_world_cam = smoothOne(poses, inputs, order, i, begin, end, half_window_s);
    begin = end;
  }
  return out;
}

Trajectory bridgeUnusable(const Trajectory& poses, const std::vector<SmoothingInput>& inputs_in) {
  const std::optional<std::vector<SmoothingInput>> inputs = checkedInputs(poses, inputs_in);
  if (!inputs) return poses;
  std::vector<size_t> order(poses.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return poses[a].timestamp < poses[b].timestamp; });
  auto usable = [&](size_t i) { return (*inputs)[i].usable; };
  Trajectory out = poses;
  std::optional<size_t> before;  // the last usable pose so far, in time order
  for (size_t k = 0; k < order.size(); ++k) {
    if (usable(order[k])) {
      before = order[k];
      continue;
    }
    size_t next = k + 1;
    while (next < order.size() && !usable(order[next])) ++next;
    if (before && next < order.size()) {
      const StampedPose& a = poses[*before];
      const StampedPose& b = poses[order[next]];
      const double span = b.timestamp - a.timestamp;
      for (size_t j = k; j < next; ++j) {
        const double alpha = span > 0.0 ? (poses[order[j]].timestamp - a.timestamp) / span : 0.5;
        out[order[j]].T_world_cam = se3::normalized(se3::interpolate(a.T_world_cam, b.T_world_cam, alpha));
      }
    }
    k = next - 1;  // the loop's ++k lands on the usable pose after the gap (or the end)
  }
  return out;
}

}  // namespace rgbdmap
