#pragma once
// The map's graph state on the ingest side: the keyframe index, the pose graph (structure and current
// poses), the loop detector, the split chains waiting for a late predecessor, and the batch of additions
// for the optimiser; optimisation results are applied here. Not thread-safe: IngestPipeline calls it under
// its state lock.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/backend/optimizer_batch.hpp"
#include "rgbdmap/backend/placement.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/ingest/keyframe_index.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/model/map_server_config.hpp"
#include "rgbdmap/model/server_keyframe.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/vision/feature_cache.hpp"
#include "rgbdmap/workers/map_worker.hpp"

namespace rgbdmap {

class MapGraph {
 public:
  /// Hands what was added to the graph since the last call to the optimiser (called with the state lock
  /// held, so keep it short).
  using SubmitGraph = std::function<void(OptimizerBatch batch)>;

  /// References must outlive the graph. revision_base: added to the optimiser's revisions.
  MapGraph(const MapServerConfig& config, RobotRegistry& registry, std::shared_ptr<FeatureCache> features,
           IngestStats& stats, int64_t revision_base);

  void setSubmit(SubmitGraph submit) { submit_ = std::move(submit); }
  void setRobotCamera(int robot, const CameraIntrinsics& camera) { detector_.setRobotCamera(robot, camera); }

  /// Adds a stored keyframe to the index, the graph and the detector. `detect`: run loop detection (a live
  /// keyframe) or just index it (restore). Returns the accepted loop edges.
  std::vector<LoopEdge> integrate(const StoredKeyframe& stored, const FrameFeatures& features, bool detect,
                                  LoopStats* loop_stats);
  /// A localising robot's keyframe (never stored) matched against the map (LoopDetector::place): one vote
  /// per verified match, the pose it gives the keyframe in the matched keyframe's map. `predicted`: the
  /// map and pose odometry predicts (nearby keyframes are candidates too); `robot`: the detector's robot
  /// id for it (kLocalizeRobotBase + its index: no stored keyframe is its own); `query_id`: negative.
  std::vector<PlacementVote> placeVotes(const std::shared_ptr<const FrameFeatures>& features, int robot,
                                        int query_id, const std::optional<PlacementEstimate>& predicted,
                                        const SE3& provisional, LoopStats* loop_stats) const;
  /// The detector's robot ids of localising robots start here (registry indices are far below it).
  static constexpr int kLocalizeRobotBase = 1 << 20;
  /// The detector's loop edges into the graph; returns those added, as they are stored.
  std::vector<StoredLoop> addDetectedLoops(const std::vector<LoopEdge>& edges, int robot);
  Status addLoopEdge(const LoopEdge& edge);
  /// A restored loop edge: into the graph and the detector.
  Status restoreLoopEdge(const LoopEdge& edge);
  void applyOptimized(const MapOptimization& optimization);
  /// Hands the batch to the optimiser; `solve`: loop edges were added or chains joined; `must_solve`:
  /// chains joined or a restore (a solve whatever the loops' consistency; merging loops set batch.merge).
  void submit(bool solve = false, bool must_solve = false);
  bool batchEmpty() const { return batch_.empty(); }
  /// A late predecessor joined a split chain since the last call (an optimisation is due).
  bool takeJoined() { return std::exchange(graph_joined_, false); }

  const KeyframeIndex& index() const { return index_; }
  KeyframeIndex& index() { return index_; }
  const PoseGraph& poseGraph() const { return graph_; }
  /// Every robot with a keyframe in the graph: its current session.
  std::map<std::string, int64_t> currentSessions() const;
  /// The valid keyframes' poses, for the map worker.
  std::vector<MapNodePose> mapPoses() const;
  std::vector<ServerLoop> loops() const;
  /// maps, the feature cache's and the retrieval index's fields.
  void fillStats(IngestStats* stats) const;
  const BundleAdjustmentStats& bundleAdjustment() const { return ba_; }

 private:
  /// `prev`: the predecessor's node; `split`: it has one that is not in the graph (a new chain, placed by
  /// the odometry of its segment's latest keyframe in the graph).
  IndexedNode makeNode(const StoredKeyframe& stored, int robot, std::optional<int64_t> prev, bool split);
  void addToGraph(const IndexedNode& node, const msg::Keyframe& kf, std::optional<int64_t> prev);
  void addOdometryEdge(int64_t from, int64_t to, const SE3& T_prev_cur, const Mat6& information);
  /// The keyframe's features and camera for bundle adjustment, into batch_.
  void addToBatch(const IndexedNode& node, const std::shared_ptr<const FrameFeatures>& features,
                  const msg::Keyframe& kf, std::optional<int64_t> prev);
  /// A keyframe integrated without its predecessor: the split is counted and remembered, so that the
  /// predecessor joins it with its odometry edge if it comes after all.
  void noteSplit(const IndexedNode& node, const msg::Keyframe& kf);
  /// The odometry edge from a keyframe split off earlier to `node`, its late predecessor, if there is one.
  void joinSplitSuccessor(const IndexedNode& node);
  /// Records the rolling-shutter prediction of the step before (or after) keyframe `id`; returns the centre
  /// of its prior from what is known now.
  Vec3 noteShutterStep(int64_t id, const Vec3& w, bool before);

  const MapServerConfig& config_;
  RobotRegistry& registry_;
  /// The features of every keyframe, shared by the loop detector and the optimiser's landmark map.
  std::shared_ptr<FeatureCache> features_;
  IngestStats& stats_;
  const int64_t revision_base_;  ///< graph revisions grow across restarts: start second * 1e6 + solve number
  SubmitGraph submit_;
  KeyframeIndex index_;
  PoseGraph graph_;       ///< structure and current poses; the optimiser solves its own copy, fed by batch_
  OptimizerBatch batch_;  ///< additions since the last submit
  LoopDetector detector_;
  int64_t next_edge_id_ = 0;
  struct SplitHead {
    int64_t node_id = 0;
    SE3 T_prev_cur = SE3::Identity();
    Mat6 information = Mat6::Identity();
  };
  std::map<KeyframeKey, SplitHead> split_heads_;  ///< by the key of the predecessor that did not come
  /// The rolling-shutter predictions of the odometry steps before and after a keyframe, kept until both came:
  /// its prior is centred on their mean, the angular velocity at the keyframe rather than half a step before.
  struct ShutterSteps {
    std::optional<Vec3> before, after;
  };
  std::map<int64_t, ShutterSteps> shutter_steps_;
  bool graph_joined_ = false;                     ///< a late predecessor joined a split chain: optimise
  BundleAdjustmentStats ba_;                      ///< of the last optimisation applied
};

}  // namespace rgbdmap
