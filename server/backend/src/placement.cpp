// Placement rules: agreeing votes for a first placement, a gate around the prediction afterwards.
#include "rgbdmap/backend/placement.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <Eigen/SVD>

namespace rgbdmap {

bool posesAgree(const SE3& a, const SE3& b, double metres, double degrees) {
  const SE3 d = a.inverse() * b;
  const double angle_deg = Eigen::AngleAxisd(d.rotation()).angle() * 180.0 / M_PI;
  return d.translation().norm() <= metres && angle_deg <= degrees;
}

SE3 weightedMeanPose(const std::vector<SE3>& poses, const std::vector<double>& weights) {
  Vec3 t = Vec3::Zero();
  Mat3 r = Mat3::Zero();
  double total = 0.0;
  for (size_t i = 0; i < poses.size(); ++i) {
    t += weights[i] * poses[i].translation();
    r += weights[i] * poses[i].rotation();
    total += weights[i];
  }
  if (!(total > 0)) return poses.empty() ? SE3::Identity() : poses.front();
  Eigen::JacobiSVD<Mat3> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 rotation = svd.matrixU() * svd.matrixV().transpose();
  if (rotation.determinant() < 0) {
    Mat3 u = svd.matrixU();
    u.col(2) *= -1.0;
    rotation = u * svd.matrixV().transpose();
  }
  SE3 out = SE3::Identity();
  out.linear() = rotation;
  out.translation() = t / total;
  return out;
}

namespace {

/// The votes of `map_id` that agree with `centre`, at most one per map keyframe (its best).
PlacementEstimate gather(const std::vector<PlacementVote>& votes, int map_id, const SE3& centre,
                         double metres, double degrees) {
  std::vector<const PlacementVote*> kept;
  for (const PlacementVote& v : votes) {
    if (v.map_id != map_id || !posesAgree(centre, v.T_map_kf, metres, degrees)) continue;
    auto same = std::find_if(kept.begin(), kept.end(),
                             [&](const PlacementVote* k) { return k->map_keyframe == v.map_keyframe; });
    if (same == kept.end())
      kept.push_back(&v);
    else if (v.inliers > (*same)->inliers)
      *same = &v;
  }
  std::vector<SE3> poses;
  std::vector<double> weights;
  for (const PlacementVote* v : kept) {
    poses.push_back(v->T_map_kf);
    weights.push_back(std::max(1, v->inliers));
  }
  PlacementEstimate e;
  e.map_id = map_id;
  e.agreeing = static_cast<int>(kept.size());
  if (!poses.empty()) e.T_map_kf = weightedMeanPose(poses, weights);
  return e;
}

}  // namespace

std::optional<PlacementEstimate> placeKeyframe(const std::vector<PlacementVote>& votes,
                                               const std::optional<PlacementEstimate>& predicted,
                                               const PlacementConfig& config) {
  if (predicted) {
    const PlacementEstimate e =
        gather(votes, predicted->map_id, predicted->T_map_kf, config.track_gate_m, config.track_gate_deg);
    if (e.agreeing == 0) return std::nullopt;
    return e;
  }
  std::optional<PlacementEstimate> best;
  for (const PlacementVote& v : votes) {
    const PlacementEstimate e = gather(votes, v.map_id, v.T_map_kf, config.agree_m, config.agree_deg);
    if (!best || e.agreeing > best->agreeing) best = e;
  }
  if (!best || best->agreeing < config.first_min_agreeing) return std::nullopt;
  // Every vote of another map or far from the group is a contradiction: a place that looks like two.
  for (const PlacementVote& v : votes)
    if (v.map_id != best->map_id ||
        !posesAgree(best->T_map_kf, v.T_map_kf, 4 * config.agree_m, 4 * config.agree_deg))
      return std::nullopt;
  return best;
}

std::optional<PlacementEstimate> bestVote(const std::vector<PlacementVote>& votes) {
  const auto it =
      std::max_element(votes.begin(), votes.end(),
                       [](const PlacementVote& a, const PlacementVote& b) { return a.inliers < b.inliers; });
  if (it == votes.end()) return std::nullopt;
  return PlacementEstimate{it->map_id, it->T_map_kf, 1};
}

}  // namespace rgbdmap
