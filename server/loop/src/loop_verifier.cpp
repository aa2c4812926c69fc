#include "rgbdmap/loop/loop_verifier.hpp"

#include "rgbdmap/vision/matcher.hpp"
#include "rgbdmap/vision/pose_refiner.hpp"
#include "rgbdmap/vision/ransac.hpp"

namespace rgbdmap {

const char* toString(LoopRejection reason) {
  switch (reason) {
    case LoopRejection::kNone:
      return "accepted";
    case LoopRejection::kTooFewMatches:
      return "too_few_matches";
    case LoopRejection::kRansacFailed:
      return "ransac_failed";
    case LoopRejection::kTooFewInliers:
      return "too_few_inliers";
    case LoopRejection::kMotionTooLarge:
      return "motion_too_large";
    case LoopRejection::kInconsistentPose:
      return "inconsistent_pose";
  }
  return "unknown";
}

double motionMeasure(const SE3& T, double k1, double k2) {
  return k1 * T.translation().norm() + k2 * se3::eulerRPY(T.linear()).norm();
}

LoopThresholds localThresholds(const LoopVerifyConfig& config, std::optional<SE3> T_from_to_prior) {
  return {config.min_inliers, config.max_motion_measure, std::move(T_from_to_prior)};
}

LoopThresholds retrievalThresholds(const LoopVerifyConfig& config) {
  return {std::max(config.min_inliers, config.min_inliers_retrieval), config.max_motion_measure_retrieval,
          std::nullopt};
}

namespace {

/// Matches that pass RANSAC's inlier test under pose T.
int countGeometricInliers(const std::vector<PointMatch>& matches, const SE3& T, const PinholeCamera& camera,
                          const RansacConfig& config) {
  int n = 0;
  for (const PointMatch& m : matches) n += isGeometricInlier(m, T, camera, config) ? 1 : 0;
  return n;
}

LoopRejection checkPose(const RansacResult& ransac, const RefineResult& refined, int refined_geometric,
                        const LoopVerifyConfig& config, const LoopThresholds& thresholds, double E) {
  if (refined.inliers < thresholds.min_inliers) return LoopRejection::kTooFewInliers;
  if (E > thresholds.max_motion_measure) return LoopRejection::kMotionTooLarge;
  if (refined_geometric < config.min_refined_fraction * static_cast<double>(ransac.inliers.size()))
    return LoopRejection::kInconsistentPose;
  if (thresholds.T_from_to_prior) {
    const SE3 disagreement = thresholds.T_from_to_prior->inverse() * refined.T_cur_ref;
    if (motionMeasure(disagreement, config.k1, config.k2) > config.max_prior_disagreement)
      return LoopRejection::kInconsistentPose;
  }
  return LoopRejection::kNone;
}

}  // namespace

LoopVerification verifyLoop(int from_id, const FrameFeatures& from, int to_id, const FrameFeatures& to,
                            const PinholeCamera& camera_from, const LoopVerifyConfig& config,
                            const LoopThresholds& thresholds, const FeatureGrid* from_grid) {
  LoopVerification v;
  std::vector<FeatureMatch> raw;
  if (from_grid && thresholds.T_from_to_prior && config.guided_radius_px > 0.0) {
    v.had_prior = true;
    GuidedMatchConfig guided;
    guided.radius_px = config.guided_radius_px;
    guided.max_distance = config.matcher.max_distance;
    guided.ratio = config.matcher.ratio;
    raw = matchByProjection(from, *from_grid, to, *thresholds.T_from_to_prior, camera_from, guided);
  }
  const bool too_few = static_cast<int>(raw.size()) < config.min_matches;
  v.fallback_refused = too_few && v.had_prior && !thresholds.allow_fallback;
  if (too_few && !v.fallback_refused) {
    std::vector<char> to_mask(to.size());
    for (size_t i = 0; i < to_mask.size(); ++i) to_mask[i] = to.hasDepth(i);
    raw = matchDescriptors(from.descriptors, to.descriptors, config.matcher, &to_mask);
    v.brute_force = true;
  }
  // cur = from (the new keyframe), ref = to (the candidate): RANSAC estimates T_from_to = T_cur_ref.
  const std::vector<PointMatch> matches = toPointMatches(from, to, raw, config.scale_factor);
  v.matches = static_cast<int>(matches.size());
  if (v.matches < config.min_matches) {
    v.rejection = LoopRejection::kTooFewMatches;
    return v;
  }
  const RansacResult ransac = ransacRigid(matches, camera_from, config.ransac);
  if (!ransac.success) {
    v.rejection = LoopRejection::kRansacFailed;
    return v;
  }
  const RefineResult refined = refinePose(matches, ransac.T_cur_ref, camera_from, config.refine);
  v.inliers = refined.inliers;
  if (!se3::isValid(refined.T_cur_ref, 1e-4)) {
    v.rejection = LoopRejection::kRansacFailed;
    return v;
  }
  v.motion_measure = motionMeasure(refined.T_cur_ref, config.k1, config.k2);
  const int refined_geometric = countGeometricInliers(matches, refined.T_cur_ref, camera_from, config.ransac);
  v.rejection = checkPose(ransac, refined, refined_geometric, config, thresholds, v.motion_measure);
  if (v.rejection != LoopRejection::kNone) return v;
  v.edge =
      LoopEdge{from_id, to_id, refined.T_cur_ref, refined.information, refined.inliers, v.motion_measure, {}};
  // toPointMatches keeps the order of `raw`: match i is raw[i] (from = query, to = train).
  for (size_t i = 0; i < raw.size(); ++i)
    if (refined.inlier_mask[i]) v.edge->inlier_pairs.emplace_back(raw[i].query, raw[i].train);
  return v;
}

}  // namespace rgbdmap
