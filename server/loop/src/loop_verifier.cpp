#include "rgbdmap/loop/loop_verifier.hpp"

#include "rgbdmap/client/matcher.hpp"
#include "rgbdmap/client/pose_refiner.hpp"
#include "rgbdmap/client/ransac.hpp"

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
  }
  return "unknown";
}

double motionMeasure(const SE3& T, double k1, double k2) {
  return k1 * T.translation().norm() + k2 * se3::eulerRPY(T.linear()).norm();
}

LoopVerification verifyLoop(int from_id, const FrameFeatures& from, int to_id, const FrameFeatures& to,
                            const PinholeCamera& camera_from, const LoopVerifyConfig& config, double max_E) {
  LoopVerification v;
  std::vector<char> to_mask(to.size());
  for (size_t i = 0; i < to_mask.size(); ++i) to_mask[i] = to.hasDepth(i);
  const std::vector<FeatureMatch> raw =
      matchDescriptors(from.descriptors, to.descriptors, config.matcher, &to_mask);
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
  if (v.inliers < config.min_inliers) {
    v.rejection = LoopRejection::kTooFewInliers;
    return v;
  }
  if (v.motion_measure > max_E) {
    v.rejection = LoopRejection::kMotionTooLarge;
    return v;
  }
  v.edge =
      LoopEdge{from_id, to_id, refined.T_cur_ref, refined.information, refined.inliers, v.motion_measure};
  return v;
}

}  // namespace rgbdmap
