#pragma once
// Landmark tracks over the server's keyframes, and the bundle adjustments that refine them.
//
// A landmark is one 3-D point (map frame) with its observations: (keyframe, feature index) pairs, at most
// one per keyframe. Tracks come from two sources:
//   - verified matches: the inlier feature pairs of every accepted edge (local loops with the recent
//     keyframes, loops, inter-robot loops), added only once the pose graph kept the edge, so a false loop
//     never enters the tracks (removeMatches() takes the links of an edge the graph disabled later);
//   - matching by projection: the landmarks seen by a new keyframe's covisible keyframes are projected into
//     it and matched to nearby keypoints by descriptor (ORB-SLAM's SearchByProjection), which makes tracks
//     long. A keypoint that already belongs to another landmark fuses the two (ORB-SLAM's Fuse), unless a
//     keyframe sees both.
// A landmark is created from a pair where one side has depth (RGB-D: no triangulation needed), moves with
// its first observer when the pose graph moves keyframes, and is removed when fewer than two observations
// are left. Keyframes in different maps (robots not merged yet) never share a landmark.
//
// Bundle adjustments (bundle_adjuster.hpp) are built here: local (a keyframe's covisibility window free,
// the other observers of its landmarks fixed) and global (every keyframe of a map, its anchor fixed). Their
// outlier observations leave the tracks. Plain structs in and out; not thread-safe (one owner thread).
#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "rgbdmap/ba/bundle_adjuster.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/vision/feature_cache.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

struct LandmarkMapConfig {
  BaSolveConfig solve;
  int local_window = 10;      ///< keyframes a local BA moves: the new one and its most covisible
  int local_fixed_max = 30;   ///< other observers of the window's landmarks held fixed (most shared first)
  int min_covisibility = 15;  ///< landmarks two keyframes must share to be covisible
  int projection_keyframes = 10;       ///< covisible keyframes whose landmarks are projected into a new one
  double projection_radius_px = 6.0;   ///< search radius at octave 0 (grows with the landmark's octave)
  int projection_max_distance = 60;    ///< Hamming distance accepted when matching by projection
  double projection_ratio = 0.8;       ///< best vs second best within the radius
  double projection_depth_chi2 = 9.0;  ///< a keypoint with depth must agree with the projected depth
  int global_max_iterations = 10;      ///< iterations of a global BA (second solve)
  double global_max_time_s = 0.0;      ///< wall-clock limit of each of its two solves; 0 = none
  int global_min_observations = 2;     ///< landmarks with fewer observations stay out of a global BA
  /// A global BA estimates the rolling-shutter rotations too (else it keeps the local BAs' estimates:
  /// fewer parameters per keyframe, a cheaper solve).
  bool global_rolling_shutter = true;
  /// A global BA takes the longest tracks up to this many observations (0: all): its cost grows with them.
  int global_max_observations = 100000;
  /// A global BA takes at most this many observations of one landmark, spread evenly over its observers
  /// (0: all): the landmarks' elimination costs the square of their track length, and a long track's
  /// middle observations add little. Frees the observation budget for more landmarks.
  int global_max_track = 8;
  /// A keyframe with fewer observations in an adjustment is held there (too weakly constrained to move:
  /// e.g. a keyframe restored after a restart that only new tracks reach).
  int min_frame_observations = 30;
  /// Two keyframes of an adjustment sharing this many of its landmarks are one part of it. A part with no
  /// held keyframe (e.g. a room that only odometry steps join to the rest of a global BA) has no gauge in
  /// the adjustment: its placement as a whole is kept, only its shape refined (0: no such correction).
  int part_link_landmarks = 3;

  std::string validate() const;  ///< "" when valid, else every problem ("; "-separated)
};

/// The rolling-shutter rotation a keyframe's motion predicts: `readout_s` times the camera's angular
/// velocity, taken from the relative pose to the keyframe before (T_prev_cur, `dt_s` earlier; in the camera's
/// own frame, as w is). Zero when dt_s is not in (0, 1] s or the rotation is not finite: no prediction.
Vec3 predictedRollingShutter(const SE3& T_prev_cur, double dt_s, double readout_s);

/// A keyframe as the landmark map needs it: pose, camera, map, features (shared, read-only).
struct LandmarkKeyframe {
  int64_t id = 0;
  int map_id = 0;
  BaIntrinsics camera;
  int width = 640, height = 480;
  SE3 T_map_kf = SE3::Identity();
  std::shared_ptr<const FrameFeatures> features;
  /// The rolling-shutter rotation the camera's motion predicts (readout time x angular velocity, rad): the
  /// mean of w's prior and its first estimate.
  Vec3 w_prior = Vec3::Zero();
};

/// Inlier feature pairs of a verified edge: feature `first` of keyframe `from`, `second` of `to`.
struct EdgeMatches {
  int64_t from = 0, to = 0;
  std::vector<std::pair<int, int>> pairs;
};

/// EdgeMatches as kept for long (e.g. while an edge's matches are in the tracks, to take them out again):
/// two 16-bit feature indices per pair when every index fits (keyframes have ~1,000 features), else the
/// pairs as they came. ~13 KB per keyframe of the server's heap as pairs of ints.
struct PackedMatches {
  int64_t from = 0, to = 0;
  std::vector<uint32_t> packed;
  std::vector<std::pair<int, int>> wide;  ///< used instead when an index is negative or above 65,535
  static PackedMatches pack(EdgeMatches m);
  EdgeMatches unpack() const;  ///< the pairs in their original order
};

struct BundleResult {
  bool ok = false;
  std::string error;
  BaReport report;
  std::vector<int64_t> moved;  ///< keyframes whose poses the adjustment changed
  std::vector<int64_t>
      fixed;  ///< keyframes it held in place (their relative poses to `moved` are refined too)
  std::vector<int64_t> weak;  ///< keyframes held for too few observations (min_frame_observations): their
                              ///< relative poses to the others are not refined
  int outliers_removed = 0;   ///< observations that left their tracks
  /// Parts of the window no held keyframe observes (LandmarkMapConfig::part_link_landmarks), put back
  /// where they were as a whole, and the largest such correction (how far the solve let them drift).
  int parts_kept = 0;
  double part_shift_m = 0.0, part_shift_deg = 0.0;
  bool refused = false;  ///< the BundleCheck refused the outcome: nothing was applied (error says why)
};

/// A pose-graph edge a global BA takes as a relative-pose prior (BaPosePrior): residual
/// S * log(T_from_to^-1 * T_map_from^-1 * T_map_to), S the upper Cholesky factor of its information in that
/// residual's frame.
struct BundlePrior {
  int64_t from = 0, to = 0;
  SE3 T_from_to = SE3::Identity();
  Mat6 sqrt_information = Mat6::Identity();
};

/// Judges a bundle adjustment's outcome before it is applied: the new poses of the keyframes it moved.
/// Returns "" to apply it, else why not (nothing is applied then).
using BundleCheck = std::function<std::string(const std::vector<std::pair<int64_t, SE3>>& T_map_kf)>;

struct LandmarkStats {
  int64_t keyframes = 0, landmarks = 0, observations = 0;
  int64_t links_from_matches = 0, links_from_projection = 0, fusions = 0;
  int64_t observations_rejected = 0;  ///< by bundle adjustments (outliers) and removed edges
  int64_t landmarks_culled = 0;
  /// Heap of the tracks: landmark slots (erased ones too), observations and every keyframe's per-feature
  /// landmark ids, by element size (allocator headers and vector slack not included).
  int64_t memory_bytes = 0;
};

class LandmarkMap {
 public:
  explicit LandmarkMap(LandmarkMapConfig config = {});

  /// Fails on a duplicate id, missing features, or arrays of different lengths.
  Status addKeyframe(LandmarkKeyframe keyframe);
  /// Keyframes added from now on whose ids the cache knows keep their features only there (read back when
  /// it dropped them). A keyframe whose features cannot be read back adds no observations and no
  /// landmarks until they can. Null (the default): held here.
  void setFeatureCache(std::shared_ptr<FeatureCache> cache) { cache_ = std::move(cache); }
  bool contains(int64_t id) const { return keyframes_.count(id) != 0; }
  /// A later centre of the keyframe's rolling-shutter prior (once the step after it came: the mean of its two
  /// steps, or that step alone for a chain's first); w moves with it while no adjustment has estimated it.
  /// False: unknown id, not finite.
  bool setRollingShutterPrior(int64_t id, const Vec3& w_prior);
  /// Links the pairs into tracks (keyframes in one map only; pairs out of range are skipped). Returns the
  /// number of observations added or fused.
  int addMatches(const EdgeMatches& matches);
  /// Takes the links of these pairs out again (an edge the pose graph disabled after all): for each pair
  /// whose two features are in one landmark, the newer keyframe's observation leaves it.
  int removeMatches(const EdgeMatches& matches);
  /// Matching by projection into `id` (its pose must be current): the landmarks of its covisible keyframes,
  /// and of `seeds` (e.g. its odometry predecessor, for a keyframe no verified match linked yet) and theirs.
  /// Returns the observations added or fused.
  int extendByProjection(int64_t id, const std::vector<int64_t>& seeds = {});

  /// New poses and maps (after a pose-graph solve or a merge); each landmark moves with its first observer.
  void setPose(int64_t id, int map_id, const SE3& T_map_kf);
  std::optional<SE3> pose(int64_t id) const;
  /// The keyframe's rolling-shutter rotation as bundle adjustment estimated it (zero before).
  std::optional<Vec3> rollingShutter(int64_t id) const;

  /// Local BA around `id`; `anchor` (the map's anchor keyframe, -1 for none) stays fixed if in the window.
  /// `cancel` stops it (the poses are then left as they were).
  /// `check` (optional) may refuse the outcome.
  BundleResult localAdjust(int64_t id, int64_t anchor = -1, const std::atomic<bool>* cancel = nullptr,
                           const BundleCheck& check = {});
  /// Global BA over every keyframe of `map_id`; `anchor` (a keyframe of it) stays fixed. `priors`: edges
  /// between its keyframes that its landmarks do not cover (those with an unknown keyframe are skipped);
  /// keyframes they join are one part for keepUnheldParts.
  BundleResult globalAdjust(int map_id, int64_t anchor, const std::atomic<bool>* cancel = nullptr,
                            const BundleCheck& check = {}, const std::vector<BundlePrior>& priors = {});

  /// Landmarks keyframes a and b both observe (0 when either is unknown).
  int sharedLandmarks(int64_t a, int64_t b) const;
  /// Keyframes sharing at least min_covisibility landmarks with `id`, most shared first.
  std::vector<std::pair<int64_t, int>> covisible(int64_t id) const;
  std::vector<int64_t> keyframesOfMap(int map_id) const;
  LandmarkStats stats() const;
  /// The landmark of a keyframe's feature, -1 when none (tests).
  int64_t landmarkOf(int64_t keyframe, int feature) const;
  /// Observations of a landmark (tests); empty when it does not exist.
  std::vector<std::pair<int64_t, int>> observationsOf(int64_t landmark) const;
  std::optional<Vec3> positionOf(int64_t landmark) const;

 private:
  struct Keyframe {
    LandmarkKeyframe kf;
    std::vector<int32_t> landmark;  ///< per feature, -1 when none (landmark ids are held to int32)
    Vec3 w = Vec3::Zero();          ///< rolling-shutter rotation over the readout, estimated by BA (rad)
  };
  /// (keyframe, feature): 8 bytes, keyframe ids are held to int32 (addKeyframe).
  using Observation = std::pair<int32_t, int32_t>;
  struct Landmark {
    Vec3 p_map = Vec3::Zero();
    std::vector<Observation> obs;  ///< at most one per keyframe
    int64_t reference = -1;        ///< first observer: the landmark moves with it; -1: erased
  };
  /// Landmarks by id (ids are dense: next_landmark_ counts them): a deque of slots, an erased one keeps
  /// only its 56 bytes (as an unordered_map each landmark cost a node and a bucket besides).
  class LandmarkTable {
   public:
    Landmark* find(int64_t id) {
      return id >= 0 && static_cast<size_t>(id) < slots_.size() && slots_[id].reference >= 0 ? &slots_[id]
                                                                                             : nullptr;
    }
    const Landmark* find(int64_t id) const { return const_cast<LandmarkTable*>(this)->find(id); }
    Landmark& at(int64_t id);  ///< throws std::out_of_range for an unknown or erased id
    const Landmark& at(int64_t id) const { return const_cast<LandmarkTable*>(this)->at(id); }
    void add(int64_t id, Landmark l);  ///< id == the number of slots so far
    void erase(int64_t id);
    size_t memoryBytes(size_t observations) const;

   private:
    std::deque<Landmark> slots_;
  };
  struct Window;  // landmark_window.cpp

  // landmark_tracks.cpp
  /// The keyframe's features (from the cache when it holds them); null when they cannot be read back.
  std::shared_ptr<const FrameFeatures> featuresOf(const Keyframe& k) const;
  Vec3 pointOf(const Keyframe& k, const FrameFeatures& f, int feature) const;  ///< back-projected, map frame
  bool observes(const Landmark& l, int64_t keyframe) const;
  /// a_f, b_f: the features of a and b (featuresOf).
  int64_t createLandmark(Keyframe& a, const FrameFeatures& a_f, int fa, Keyframe& b, const FrameFeatures& b_f,
                         int fb);
  bool attach(int64_t landmark, Keyframe& k, int feature);
  void detach(int64_t landmark, int64_t keyframe);
  /// Merges `from` into `into` unless a keyframe sees both; true when merged.
  bool fuse(int64_t into, int64_t from);
  int link(Keyframe& a, const FrameFeatures& a_f, int fa, Keyframe& b, const FrameFeatures& b_f, int fb);
  void eraseIfShort(int64_t landmark);
  int descriptorDistance(const Landmark& l, const uint8_t* descriptor) const;
  // landmark_window.cpp
  Window localWindow(int64_t id, int64_t anchor) const;
  Window globalWindow(int map_id, int64_t anchor) const;
  BaProblem problemOf(const Window& w) const;
  void keepUnheldParts(const BaProblem& p, BaSolution* s, BundleResult* out) const;
  BundleResult solveAndApply(const Window& w, int second_iterations, double max_time_s, bool rolling_shutter,
                             const std::atomic<bool>* cancel, const BundleCheck& check);

  LandmarkMapConfig config_;
  std::unordered_map<int64_t, Keyframe> keyframes_;
  LandmarkTable landmarks_;
  int64_t next_landmark_ = 0;
  int64_t feature_slots_ = 0;  ///< features of every keyframe (their landmark ids)
  LandmarkStats stats_;
  std::shared_ptr<FeatureCache> cache_;
};

}  // namespace rgbdmap
