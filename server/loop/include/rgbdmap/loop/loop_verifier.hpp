#pragma once
// Geometric verification of a loop candidate with the client's pose pipeline (brute-force matching,
// 3-D RANSAC, robust refinement) and the motion measure of Hu et al. 2017, eq. (5):
//   E = k1 * |t|_2 + k2 * |(roll, pitch, yaw)|_2,  t in metres, Euler angles in radians (se3::eulerRPY).
// E is a weighted sum of metres and radians; k1 has units 1/m and k2 1/rad so E is a pure number.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/vision/features.hpp"
#include "rgbdmap/vision/guided_match_config.hpp"
#include "rgbdmap/vision/guided_matcher.hpp"
#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

struct LoopVerifyConfig {
  int min_matches = 30;  ///< descriptor matches (with depth on the candidate) needed to try RANSAC
  /// Refined inliers needed to accept the loop. On fr1_rpy (RealLoop test) edges with 40-49 inliers erred
  /// 4.0 cm on average and up to 14.8 cm against the ground truth, those with 50 or more 2.5 cm and 6.8 cm.
  int min_inliers = 50;
  double k1 = 0.35;      ///< weight of the translation norm, 1/m (paper: 0.3-0.4)
  double k2 = 1.0;       ///< weight of the Euler-angle norm, 1/rad (paper: 1)
  /// E threshold for local candidates (recent, random, nearby): the paper's "small motion" test. 0.6 is,
  /// e.g., 0.5 m with 24 deg, or 1.7 m with no rotation.
  double max_motion_measure = 0.6;
  /// E threshold when the candidate came (also) from appearance retrieval: a true revisit can be far in
  /// pose, so E only guards against absurd results there (2.0 ~ 1.5 m with 85 deg); the inlier count and
  /// the reprojection/depth inlier test of RANSAC and refinement carry the decision.
  double max_motion_measure_retrieval = 2.0;
  /// Retrieval hits need more evidence: aliasing (repeated objects, similar texture) shows up there and
  /// no pose prior can veto it. Measured on the synthetic room: true revisits 90-205 inliers, aliased
  /// pairs of views 90+ deg apart up to 66.
  int min_inliers_retrieval = 80;
  /// The refined pose must still pass RANSAC's own inlier test for this fraction of RANSAC's inliers;
  /// otherwise refinement slid to another pose (aliased geometry) and neither is trustworthy. Measured:
  /// accepted true loops 0.91-1.28 (fr1_rpy) and 0.86-1.0 (synthetic); an aliased local loop 0.71.
  double min_refined_fraction = 0.8;
  /// Local candidates in the same map frame: E of the disagreement between the verified relative pose and
  /// the one from the current pose estimates must not exceed this (odometry drift over a local loop is far
  /// smaller; an aliased match is not).
  double max_prior_disagreement = 1.0;
  /// Candidates with a pose prior (same map) are matched by projection under the prior first: each of the
  /// candidate's 3-D points is compared only with keypoints within this radius (scaled by octave) of its
  /// projection, instead of all of them (several times faster than brute force). Falls back to brute force
  /// when that finds fewer than min_matches (a prior off by more than the radius). 0 turns it off.
  double guided_radius_px = 40.0;
  float scale_factor = 1.2f;  ///< ORB pyramid scale of the features (for keypoint noise by octave)
  MatcherConfig matcher;
  RansacConfig ransac;
  RefineConfig refine;
};

enum class LoopRejection {
  kNone = 0,
  kTooFewMatches,
  kRansacFailed,
  kTooFewInliers,
  kMotionTooLarge,
  kInconsistentPose,  ///< refinement slid off RANSAC's pose, contradicts the prior, or fails triangles
};
constexpr int kLoopRejectionCount = 6;
/// "accepted", "too_few_matches", "ransac_failed", "too_few_inliers", "motion_too_large",
/// "inconsistent_pose".
const char* toString(LoopRejection reason);

/// A verified loop edge. Convention: from = the new keyframe, to = the candidate, p_from = T_from_to * p_to.
struct LoopEdge {
  int from_id = -1;
  int to_id = -1;
  SE3 T_from_to = SE3::Identity();
  Mat6 information = Mat6::Zero();  ///< of T_from_to, tangent order (rho, omega), left perturbation
  int inliers = 0;
  double motion_measure = 0.0;  ///< E
  /// The refined inliers as feature index pairs (from's feature, to's feature): the landmark tracks of
  /// bundle adjustment are made of them. Empty for edges restored from the map store.
  std::vector<std::pair<int, int>> inlier_pairs;
};

struct LoopVerification {
  std::optional<LoopEdge> edge;  ///< set when accepted
  LoopRejection rejection = LoopRejection::kNone;
  int matches = 0;
  int inliers = 0;
  double motion_measure = 0.0;  ///< E of the refined pose (0 if none was estimated)
  bool had_prior = false;    ///< matched by projection under the prior pose first (a grid and a prior given)
  bool brute_force = false;  ///< matched all against all: no prior, or too few matches by projection
  bool fallback_refused = false;  ///< too few matches by projection and LoopThresholds::allow_fallback false
};

/// E = k1 |t| + k2 |eulerRPY(R)| of a relative pose.
double motionMeasure(const SE3& T, double k1, double k2);

/// Acceptance thresholds for one candidate (local or retrieval; see the config).
struct LoopThresholds {
  int min_inliers = 50;
  double max_motion_measure = 0.6;
  std::optional<SE3> T_from_to_prior;  ///< from the pose estimates, when comparable (same map frame)
  /// With a prior: match all against all when matching by projection finds too few (else reject then).
  bool allow_fallback = true;
};
LoopThresholds localThresholds(const LoopVerifyConfig& config, std::optional<SE3> T_from_to_prior);
LoopThresholds retrievalThresholds(const LoopVerifyConfig& config);

/// Verifies `to` (candidate, needs depth) against `from` (new keyframe, seen by `camera_from`).
/// `from_grid` (a FeatureGrid over `from`, optional) enables matching by projection when the thresholds
/// carry a prior.
LoopVerification verifyLoop(int from_id, const FrameFeatures& from, int to_id, const FrameFeatures& to,
                            const PinholeCamera& camera_from, const LoopVerifyConfig& config,
                            const LoopThresholds& thresholds, const FeatureGrid* from_grid = nullptr);

}  // namespace rgbdmap
