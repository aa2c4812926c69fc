#pragma once
// Loop closure on the server: holds the keyframes of all robots, and for each new keyframe selects
// candidates (recent, random, nearby, appearance retrieval), verifies them geometrically and returns the
// accepted loop edges with statistics. Plain structs in and out: no transport, files or threads.
#include <array>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/loop/binary_words.hpp"
#include "rgbdmap/loop/loop_candidates.hpp"
#include "rgbdmap/loop/loop_consistency.hpp"
#include "rgbdmap/loop/loop_verifier.hpp"
#include "rgbdmap/vision/feature_cache.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

struct LoopDetectorConfig {
  LoopCandidateConfig candidates;
  LoopVerifyConfig verify;
  BinaryWordsConfig words;
  LoopConsistencyConfig consistency;
  double min_retrieval_score = 0.02;  ///< retrieval hits scoring below this are not candidates
  /// The caller's measured priors (addKeyframe's `measured`): relative poses composed from the pose graph's
  /// measurements over paths of at most this many hops from the new keyframe (0: none), up to
  /// prior_max_nodes keyframes. A candidate with one is checked against it (max_prior_disagreement) and
  /// matched by projection, retrieval hits included: a symmetric room's views 90 deg apart match each other
  /// (aliasing), and a few hops of odometry know better.
  int prior_max_hops = 40;
  int prior_max_nodes = 4000;
  /// Candidates with a prior pose that one keyframe may match all against all after matching by
  /// projection found too few matches, best retrieval score first (0: no limit). At 20,000
  /// keyframes of bench_map_growth that fallback was ~40 % of the ingest thread and verified 11 of 123,821;
  /// it exists for priors that drift made wrong, which that world does not measure: off by default.
  int max_fallbacks_per_keyframe = 0;

  /// Checks every value's range; returns an empty string when valid, else all reasons ("; "-separated).
  /// Apps call this once at start-up; the detector itself clamps nothing.
  std::string validate() const;
};

/// A keyframe as the server stores it. The features are shared, not copied: the server's bundle
/// adjustment holds the same ones (one copy per keyframe in RAM).
struct LoopKeyframe {
  LoopKeyframe() = default;
  LoopKeyframe(int id_, int robot_id_, int map_id_, const SE3& T_map_kf_,
               std::shared_ptr<const FrameFeatures> features_)
      : id(id_), robot_id(robot_id_), map_id(map_id_), T_map_kf(T_map_kf_), features(std::move(features_)) {}
  /// Takes a copy of the features (tests, benchmarks).
  LoopKeyframe(int id_, int robot_id_, int map_id_, const SE3& T_map_kf_, FrameFeatures features_)
      : LoopKeyframe(id_, robot_id_, map_id_, T_map_kf_,
                     std::make_shared<const FrameFeatures>(std::move(features_))) {}

  int id = -1;  ///< unique over all robots
  int robot_id = 0;
  int map_id = 0;  ///< frame of T_map_kf (e.g. the robot's own map until maps are merged)
  SE3 T_map_kf = SE3::Identity();
  /// With depth and 3-D points (client OrbExtractor); addKeyframe and restoreKeyframe refuse null. Null
  /// in a stored keyframe only when a FeatureCache holds them (setFeatureCache).
  std::shared_ptr<const FrameFeatures> features;
};

struct LoopStats {
  std::array<int, kCandidateSourceCount> candidates_by_source{};  ///< a candidate counts for every source
  int candidates = 0;                                             ///< after dedup and cap
  int verified = 0;
  /// Candidates matched all against all (the costly path): without a prior pose, or because
  /// matching by projection under the prior found too few matches.
  int brute_force_no_prior = 0, brute_force_fallback = 0;
  /// Of the fallbacks, those the verification accepted (what bounding the fallback would lose at most).
  int brute_force_fallback_verified = 0;
  /// Candidates rejected without the fallback: the keyframe's max_fallbacks_per_keyframe were spent.
  int fallbacks_skipped = 0;
  /// Candidates skipped because their features were paged out and could not be read back (FeatureCache).
  int features_unavailable = 0;
  std::array<int, kLoopRejectionCount> rejected_by_reason{};  ///< index = LoopRejection (0 unused)
  double retrieval_ms = 0.0;                                  ///< words + query + insert
  double verify_ms = 0.0;
  double total_ms = 0.0;
};

struct LoopDetection {
  std::vector<LoopEdge> edges;
  std::vector<LoopCandidate> candidates;
  LoopStats stats;
};

class LoopDetector {
 public:
  /// default_camera is used for robots without setRobotCamera().
  LoopDetector(const CameraIntrinsics& default_camera, const LoopDetectorConfig& config = {});

  void setRobotCamera(int robot_id, const CameraIntrinsics& intrinsics);
  /// Keyframes added from now on whose ids the cache knows (the caller adds them to it first) keep their
  /// features only there: LoopKeyframe::features of a stored keyframe is then null, and a candidate's
  /// features come from the cache (read back when it dropped them). Null (the default): held here.
  void setFeatureCache(std::shared_ptr<FeatureCache> cache);
  /// Relative poses T_kf_other of keyframes near a new one, from measurements alone (odometry and verified
  /// loops along a few hops: PoseGraph::measuredPosesNear), by keyframe id.
  using MeasuredPoses = std::unordered_map<int64_t, SE3>;
  /// Stores the keyframe, finds and verifies its loops. A candidate in `measured` (optional) must agree
  /// with that relative pose (max_prior_disagreement), whatever its source; other candidates in the same
  /// map are checked against the pose estimates, local ones only. Fails (nothing stored) on a duplicate id
  /// or on features whose arrays disagree in size.
  Result<LoopDetection> addKeyframe(LoopKeyframe keyframe, const MeasuredPoses* measured = nullptr);
  /// Place recognition without storing (a robot that localises in the map): candidates are the retrieval
  /// hits among the stored keyframes and, when query.map_id names a stored map, the stored keyframes near
  /// query.T_map_kf (a predicted pose) in it, each verified as a loop is (a nearby one under the predicted
  /// relative pose as its prior). Nothing of the query is kept and the totals do not change. query.id must
  /// not be a stored id; query.robot_id should have no stored keyframes (recent and random candidates are of
  /// the same robot). Fails on features whose arrays disagree in size.
  Result<LoopDetection> place(const LoopKeyframe& query) const;
  /// Restart path: stores and indexes a keyframe that was verified before (no candidates, no verification),
  /// in the original order, so retrieval and recent/random candidates continue as before the restart.
  Status restoreKeyframe(LoopKeyframe keyframe);
  /// Restart path: a loop edge accepted before, for the triangle-consistency check of later loops.
  void restoreEdge(const LoopEdge& edge);
  /// New pose estimate (e.g. after pose-graph optimisation or a map merge). False if the id is unknown.
  bool updatePose(int keyframe_id, int map_id, const SE3& T_map_kf);

  size_t size() const { return keyframes_.size(); }
  /// Heap of the retrieval index (its posting lists), the largest part of the detector that grows with the
  /// map.
  size_t retrievalIndexBytes() const { return index_.memoryBytes(); }
  /// A stored keyframe; its `features` are null when a FeatureCache holds them.
  const LoopKeyframe* find(int keyframe_id) const;
  const LoopStats& totals() const { return totals_; }

 private:
  std::vector<RetrievalHit> retrieve(const LoopKeyframe& kf, int robot_sequence,
                                     const WordHistogram& words) const;
  LoopThresholds thresholdsFor(const LoopKeyframe& kf, const LoopCandidate& c, const LoopKeyframe& other,
                               const MeasuredPoses* measured) const;
  void verifyCandidates(const LoopKeyframe& kf, const MeasuredPoses* measured, LoopDetection* out) const;
  const PinholeCamera& cameraOf(int robot_id) const;
  void dropInconsistent(LoopDetection* out) const;
  void accumulate(const LoopStats& s);
  void store(LoopKeyframe keyframe);
  std::shared_ptr<const FrameFeatures> featuresOf(const LoopKeyframe& kf) const;  ///< null: unavailable

  LoopDetectorConfig config_;
  PinholeCamera default_camera_;
  std::map<int, PinholeCamera> robot_cameras_;
  BinaryWordHasher hasher_;
  BinaryWordIndex index_;
  std::vector<LoopKeyframe> keyframes_;      ///< insertion order
  std::vector<KeyframeSummary> summaries_;   ///< same order
  std::unordered_map<int, size_t> slot_of_;  ///< keyframe id -> index
  std::map<int, int> robot_count_;           ///< keyframes per robot (next robot sequence)
  LoopEdgeStore accepted_;                   ///< verified loop edges, for the consistency check
  std::mt19937 rng_;
  LoopStats totals_;
  std::shared_ptr<FeatureCache> cache_;
};

}  // namespace rgbdmap
