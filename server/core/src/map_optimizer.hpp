#pragma once
// The map optimiser: one worker thread that owns the optimisation state of every map
//   - the pose graph: robust loop rejection, map merging, the fast first answer after a loop;
//   - the landmark map: tracks over the keyframes' features, local bundle adjustment after each keyframe and
//     global bundle adjustment after a loop that closes a large cycle, a merge, or when the map is quiet.
// The ingest worker hands it additions (OptimizerBatch: nodes, edges, features, the inlier pairs of loop
// edges), never a copy of the whole graph; batches that arrive while it works are taken together. Each
// batch ends with a result (every node's pose, disabled edges, components) that the ingest worker applies
// and turns into corrections. Matches of a loop edge enter the tracks only once the pose graph kept the
// edge, and leave them if it disables the edge later: a false loop never shapes the landmarks.
// After a bundle adjustment the edges between the keyframes it refined take the refined relative poses as
// their measurements (ORB-SLAM's essential graph), so a later pose-graph solve spreads a loop's correction
// without undoing the refinement.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/backend/global_bundle_schedule.hpp"
#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/common/sample_reservoir.hpp"
#include "rgbdmap/common/serial_worker.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_optimizer.hpp"
#include "rgbdmap/server/map_server.hpp"

namespace rgbdmap {

struct MapOptimizerConfig {
  PoseGraphConfig graph;
  BundleAdjustmentConfig ba;
  int nice = 0;  ///< the worker thread's nice above the process (server.background_nice)
  /// Where the landmark map takes the keyframes' features from (null: the batches' copies are kept).
  std::shared_ptr<FeatureCache> features;
};

/// What the ingest worker hands over after a keyframe (or a restore).
struct OptimizerBatch {
  std::vector<PoseGraphNode> nodes;         ///< new keyframes; a node with an odometry edge to a known
                                            ///< predecessor is placed by it, the others at their pose
  std::vector<PoseGraphEdge> edges;         ///< new odometry and loop edges
  std::vector<LandmarkKeyframe> keyframes;  ///< features of new keyframes, for bundle adjustment
  std::map<int64_t, EdgeMatches> matches;   ///< inlier pairs of new loop edges, by edge id
  bool solve = false;                       ///< loop edges added or chains joined: a pose-graph solve first
  /// Chains joined or a restore: solve whatever the loops' consistency (solve_above_chi2).
  bool must_solve = false;
  /// Loop edges between two maps: each map met for the first time is first moved rigidly onto the map it
  /// joins (PoseGraph::alignSubmaps); a solve follows only if the new edges, or those the move changed,
  /// disagree with the result beyond solve_above_chi2 (a robot's new chain joining a large map costs a
  /// rigid move, not a solve of the whole graph).
  bool merge = false;
  bool global = false;  ///< a global BA of every map changed since its last one (waitIdle)
  bool empty() const {
    return nodes.empty() && edges.empty() && keyframes.empty() && !solve && !must_solve && !merge && !global;
  }
  void append(OptimizerBatch&& other);
};

struct MapOptimization {
  uint64_t revision = 0;  ///< the highest submit() this result includes
  OptimizedPoses graph;   ///< poses of every node, disabled edges, components; report of the last solve
  bool graph_solved = false;
  BundleAdjustmentStats ba;
  int solves_skipped = 0;  ///< batches with loops that needed no solve (all within solve_above_chi2), so far
  int merges_aligned = 0;  ///< batches whose merging maps were moved rigidly (merge), so far
  int local_solves = 0;    ///< pose-graph solves of new loops' neighbourhood kept (optimizeLocal), so far
  int local_refused = 0;   ///< local solves refused (a whole-graph solve followed), so far
};

class MapOptimizer {
 public:
  using Callback = std::function<void(const std::shared_ptr<const MapOptimization>&)>;

  MapOptimizer(MapOptimizerConfig config, Callback callback);
  ~MapOptimizer();  ///< stop()
  MapOptimizer(const MapOptimizer&) = delete;
  MapOptimizer& operator=(const MapOptimizer&) = delete;

  /// Queues a batch and returns its revision at once (0 after stop()); its result comes to the callback.
  uint64_t submit(OptimizerBatch batch);
  /// A map changed since its last global BA, or neighbourhood solves since the last whole-graph one (what a
  /// submit with `global` would do something for).
  bool globalDue() const;
  /// Cancels a running solve, drops pending batches and joins the worker. Idempotent.
  void stop();

 private:
  void processPending();  ///< a task on worker_: every pending batch as one
  void onIdle();          ///< worker_'s period: the deferred whole-graph solve and global BA when quiet
  void applyAdditions(const OptimizerBatch& b);
  void refreshMaps();  ///< map id (= first node of its component) and anchor of every node
  /// Solves the pose graph: the neighbourhood of `seeds` (edge ids) first when there are any and
  /// graph.local_max_nodes > 0, the whole graph when that answer is refused or there are none.
  bool solveGraph(OptimizedPoses* out, const std::vector<int64_t>& seeds = {});
  /// Whether the batch's loops need a whole-graph solve (PoseGraphConfig::solve_above_chi2); when not,
  /// its loop edges count as judged (kept) without one.
  bool needsSolve(const OptimizerBatch& b, std::vector<int64_t>* seeds);
  /// Matches of kept edges into the tracks, of disabled edges out. Returns whether a large cycle closed;
  /// *chains_joined: whether an edge between two chains (a merge, a split rejoined) came into the tracks.
  bool updateTracks(bool* chains_joined);
  size_t keyframesIn(int map) const;  ///< keyframes of the map (a scan of map_of_)
  void adjustNewKeyframes(const std::vector<int64_t>& ids);
  void adjustGlobally(const std::set<int>& maps);
  /// The enabled edges of `map` whose keyframes share too few landmarks for a BA to know their relative pose,
  /// as priors for its global BA (BundleAdjustmentConfig::global_step_priors).
  std::vector<BundlePrior> stepPriors(int map) const;
  /// An enabled edge at a keyframe of an adjustment whose two keyframes share landmarks: the relative pose
  /// the adjustment's poses give it, and how far that is from its measurement.
  struct CovisibleEdge {
    const PoseGraphEdge* edge;
    SE3 measured;
    double t, deg;
  };
  /// The covisible edges at the keyframes of `poses` (their new poses; the graph's for the other end), once.
  std::vector<CovisibleEdge> covisibleEdgeChanges(const std::vector<std::pair<int64_t, SE3>>& poses) const;
  /// Refuses an adjustment that moves an edge between covisible keyframes beyond max_edge_change_*.
  std::string checkBundle(const std::vector<std::pair<int64_t, SE3>>& proposed);
  /// Counts a finished adjustment (refused, parts kept); true when it was applied.
  bool countBundle(const BundleResult& r, const char* kind);
  void applyBundle(const BundleResult& r);
  void publish(uint64_t revision, bool solved, const OptimizedPoses& solve);
  /// Logs (info) a result that moved a tenth of the keyframes or more, with the work that moved them.
  void logMoves(const std::map<int64_t, SE3>& poses);
  bool isLargeCycle(const PoseGraphEdge& e) const;
  std::vector<int64_t> odometryNeighbours(int64_t id) const;

  MapOptimizerConfig config_;
  Callback callback_;
  std::atomic<bool> cancel_{false};
  const BundleCheck check_ = [this](const std::vector<std::pair<int64_t, SE3>>& proposed) {
    return checkBundle(proposed);
  };

  mutable std::mutex mutex_;  ///< pending_, revisions, stopping_, due_
  OptimizerBatch pending_;
  uint64_t pending_revision_ = 0;
  uint64_t next_revision_ = 1;
  bool task_queued_ = false;
  bool stopping_ = false;
  bool global_due_ = false;
  std::chrono::steady_clock::time_point last_batch_ = std::chrono::steady_clock::now();

  // ---- the worker's own state
  PoseGraph graph_;
  LandmarkMap landmarks_;
  std::map<int64_t, int> map_of_;                          ///< node -> map id (first node of its component)
  std::map<int, int64_t> anchor_of_;                       ///< map id -> the node that holds its gauge
  std::map<int64_t, int> chain_of_;                        ///< node -> its chain (PoseGraphNode::robot)
  std::map<int64_t, std::vector<int64_t>> edges_of_node_;  ///< node -> ids of its edges
  struct Waiting {
    EdgeMatches matches;
    bool checked = false;  ///< a pose-graph solve has judged the edge since it came
  };
  std::map<int64_t, Waiting> waiting_;  ///< matches of edges not in the tracks (yet)
  /// Matches of edges in the tracks, kept only to take them out again if the graph disables the edge.
  std::map<int64_t, PackedMatches> in_tracks_;
  GlobalBundleSchedule schedule_;  ///< which maps are due a global BA
  struct {
    std::vector<int64_t> moved;        ///< the keyframes of the outcome checkBundle saw last
    std::vector<CovisibleEdge> edges;  ///< its covisible edges, for applyBundle
  } checked_;
  std::set<std::string> causes_;       ///< work done since the last result (logMoves)
  std::map<int64_t, SE3> published_;   ///< poses of the last result (logMoves)
  BundleAdjustmentStats counters_;
  int solves_skipped_ = 0;
  int merges_aligned_ = 0;
  bool graph_stale_ = false;  ///< neighbourhood solves since the last whole-graph one (due when quiet)
  int local_solves_ = 0;
  int local_refused_ = 0;
  SampleReservoir local_ms_, local_cpu_ms_;
  SerialWorker worker_;  ///< last: stopped before the state above goes away
};

}  // namespace rgbdmap
