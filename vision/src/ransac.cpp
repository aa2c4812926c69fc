#include "rgbdmap/vision/ransac.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>

#include "rgbdmap/common/alignment.hpp"

namespace rgbdmap {

std::vector<PointMatch> toPointMatches(const FrameFeatures& cur, const FrameFeatures& ref,
                                       const std::vector<FeatureMatch>& matches, float scale_factor) {
  std::vector<PointMatch> out;
  out.reserve(matches.size());
  for (const auto& m : matches) {
    PointMatch pm;
    pm.p_ref = ref.p_cam[m.train];
    pm.p_cur = cur.hasDepth(m.query) ? cur.p_cam[m.query] : Vec3::Zero();
    pm.px_cur = cur.px[m.query];
    pm.px_ref = ref.px[m.train];
    pm.sigma_px = std::pow(scale_factor, cur.keypoints[m.query].octave);
    out.push_back(pm);
  }
  return out;
}

bool isGeometricInlier(const PointMatch& m, const SE3& T_cur_ref, const PinholeCamera& camera,
                       const RansacConfig& config) {
  const Vec3 q = T_cur_ref * m.p_ref;
  const auto px = camera.project(q);
  if (!px) return false;
  const double thr = config.reprojection_threshold_px * m.sigma_px;
  if ((*px - m.px_cur).squaredNorm() > thr * thr) return false;
  if (m.p_cur.z() <= 0) return true;  // no depth in the current frame: reprojection alone decides
  return std::abs(q.z() - m.p_cur.z()) <= config.depth_threshold_rel * m.p_cur.z();
}

namespace {

std::vector<int> collectInliers(const std::vector<PointMatch>& matches, const SE3& T,
                                const PinholeCamera& camera, const RansacConfig& config) {
  std::vector<int> inliers;
  for (size_t i = 0; i < matches.size(); ++i)
    if (isGeometricInlier(matches[i], T, camera, config)) inliers.push_back(static_cast<int>(i));
  return inliers;
}

// A rigid motion preserves distances: reject samples whose pairwise distances differ too much.
bool sampleIsRigid(const PointMatch& a, const PointMatch& b, const PointMatch& c, double rel_tol) {
  auto consistent = [rel_tol](const PointMatch& x, const PointMatch& y) {
    const double d_ref = (x.p_ref - y.p_ref).norm(), d_cur = (x.p_cur - y.p_cur).norm();
    return d_ref > 0.05 && std::abs(d_ref - d_cur) <= rel_tol * std::max(d_ref, d_cur) + 0.01;
  };
  return consistent(a, b) && consistent(b, c) && consistent(a, c);
}

// Closed-form solve on the listed matches that have depth on both sides.
std::optional<SE3> solveOn(const std::vector<PointMatch>& matches, const std::vector<int>& idx) {
  std::vector<Vec3> src, dst;
  src.reserve(idx.size());
  dst.reserve(idx.size());
  for (int i : idx) {
    if (matches[i].p_cur.z() <= 0) continue;
    src.push_back(matches[i].p_ref);
    dst.push_back(matches[i].p_cur);
  }
  const auto aligned = alignUmeyama(src, dst);  // T_gt_est with gt = current, est = reference
  if (!aligned) return std::nullopt;
  return aligned->T_gt_est;
}

int requiredIterations(double inlier_ratio, double confidence, int max_iterations) {
  const double p_good = std::pow(std::clamp(inlier_ratio, 1e-6, 1.0), 3);
  if (p_good >= 1.0 - 1e-12) return 1;
  const double n = std::log(1.0 - confidence) / std::log(1.0 - p_good);
  return static_cast<int>(std::min<double>(max_iterations, std::ceil(n)));
}

}  // namespace

RansacResult ransacRigid(const std::vector<PointMatch>& matches, const PinholeCamera& camera,
                         const RansacConfig& config) {
  RansacResult result;
  const int n = static_cast<int>(matches.size());
  std::vector<int> with_depth;  // minimal samples need 3-D on both sides
  for (int i = 0; i < n; ++i)
    if (matches[i].p_cur.z() > 0 && matches[i].p_ref.z() > 0) with_depth.push_back(i);
  if (static_cast<int>(with_depth.size()) < std::max(3, config.min_inliers)) return result;
  std::mt19937 rng(config.seed);
  std::uniform_int_distribution<int> pick_idx(0, static_cast<int>(with_depth.size()) - 1);
  auto pick = [&](std::mt19937& g) { return with_depth[pick_idx(g)]; };
  int needed = config.max_iterations;
  SE3 best_T = SE3::Identity();
  size_t best_count = 0;
  int it = 0;
  for (; it < needed; ++it) {
    const int a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    if (!sampleIsRigid(matches[a], matches[b], matches[c], 0.1)) continue;
    const auto T = solveOn(matches, {a, b, c});
    if (!T) continue;
    const auto inliers = collectInliers(matches, *T, camera, config);
    if (inliers.size() > best_count) {
      best_count = inliers.size();
      best_T = *T;
      needed = std::max(20, requiredIterations(double(best_count) / with_depth.size(), config.confidence,
                                               config.max_iterations));
    }
  }
  result.iterations = it;
  if (static_cast<int>(best_count) < config.min_inliers) return result;
  // Local optimisation: re-solve on all inliers, then re-collect (twice is enough in practice).
  std::vector<int> inliers = collectInliers(matches, best_T, camera, config);
  for (int round = 0; round < 2; ++round) {
    const auto T = solveOn(matches, inliers);
    if (!T) break;
    auto refined = collectInliers(matches, *T, camera, config);
    if (refined.size() < inliers.size()) break;
    best_T = *T;
    inliers = std::move(refined);
  }
  result.success = static_cast<int>(inliers.size()) >= config.min_inliers;
  result.T_cur_ref = best_T;
  result.inliers = std::move(inliers);
  return result;
}

}  // namespace rgbdmap
