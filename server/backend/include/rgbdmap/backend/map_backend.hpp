#pragma once
// The map back-end: the optimisation state of every map and what is done with it, without threads.
//   - the pose graph: robust loop rejection, map merging, the fast first answer after a loop (a solve of the
//     new loops' neighbourhood, the whole graph when that is refused or the map is quiet);
//   - the landmark map: tracks over the keyframes' features, local bundle adjustment after each keyframe and
//     global bundle adjustment after a loop that closes a large cycle, a merge, or when the map is quiet
//     (GlobalBundleSchedule);
//   - each adjustment's outcome checked (BundleOutcome) and applied with the essential-graph edge rewrite
//     (EssentialGraph);
//   - the topology indices (MapTopology).
// It takes additions (OptimizerBatch), never a copy of the whole graph, and answers each with a result
// (every node's pose, disabled edges, components, counters). Matches of a loop edge enter the tracks only
// once the pose graph kept the edge, and leave them if it disables the edge later: a false loop never shapes
// the landmarks. The caller runs it on one thread; cancel() may come from any thread.
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/backend/bundle_adjustment_config.hpp"
#include "rgbdmap/backend/bundle_outcome.hpp"
#include "rgbdmap/backend/essential_graph.hpp"
#include "rgbdmap/backend/global_bundle_schedule.hpp"
#include "rgbdmap/backend/map_topology.hpp"
#include "rgbdmap/backend/optimizer_batch.hpp"
#include "rgbdmap/common/sample_reservoir.hpp"
#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap {

struct MapBackendConfig {
  PoseGraphConfig graph;
  BundleAdjustmentConfig ba;
  /// Where the landmark map takes the keyframes' features from (null: the batches' copies are kept).
  std::shared_ptr<FeatureCache> features;
};

class MapBackend {
 public:
  explicit MapBackend(MapBackendConfig config);
  MapBackend(const MapBackend&) = delete;
  MapBackend& operator=(const MapBackend&) = delete;

  /// Adds the batch, solves the pose graph when its loops need it, moves kept loops' matches into the tracks,
  /// runs the local and the due global bundle adjustments. Null when cancelled.
  std::shared_ptr<MapOptimization> runBatch(const OptimizerBatch& b);
  /// What a quiet map gets: the whole-graph solve after neighbourhood solves, the global BA of every changed
  /// map. Null when cancelled.
  std::shared_ptr<MapOptimization> runIdle();
  /// A map changed since its last global BA, or neighbourhood solves since the last whole-graph one (what a
  /// batch with `global`, or runIdle(), would do something for).
  bool globalDue() const;
  /// Stops a running solve or adjustment; every later run returns null. Thread-safe.
  void cancel() { cancel_ = true; }

 private:
  void applyAdditions(const OptimizerBatch& b);
  void refreshMaps();  ///< the topology's maps and anchors; landmarks follow keyframes that changed map
  /// Solves the pose graph: the neighbourhood of `seeds` (edge ids) first when there are any and
  /// graph.local_max_nodes > 0, the whole graph when that answer is refused or there are none.
  bool solveGraph(OptimizedPoses* out, const std::vector<int64_t>& seeds = {});
  /// Whether the batch's loops need a whole-graph solve (PoseGraphConfig::solve_above_chi2); when not,
  /// its loop edges count as judged (kept) without one.
  bool needsSolve(const OptimizerBatch& b, std::vector<int64_t>* seeds);
  /// Matches of kept edges into the tracks, of disabled edges out. Returns whether a large cycle closed;
  /// *chains_joined: whether an edge between two chains (a merge, a split rejoined) came into the tracks.
  bool updateTracks(bool* chains_joined);
  void adjustNewKeyframes(const std::vector<int64_t>& ids);
  void adjustGlobally(const std::set<int>& maps);
  void applyBundle(const BundleResult& r);
  std::shared_ptr<MapOptimization> result(bool solved, const OptimizedPoses& solve);
  /// Logs (info) a result that moved a tenth of the keyframes or more, with the work that moved them.
  void logMoves(const std::map<int64_t, SE3>& poses);

  MapBackendConfig config_;
  std::atomic<bool> cancel_{false};
  PoseGraph graph_;
  LandmarkMap landmarks_;
  MapTopology topology_;
  EssentialGraph essential_{&graph_, &landmarks_, &topology_};
  BundleOutcome outcome_{&config_.ba, &graph_, &landmarks_, &topology_, &essential_};
  const BundleCheck check_ = [this](const std::vector<std::pair<int64_t, SE3>>& proposed) {
    return outcome_.check(proposed);
  };
  struct Waiting {
    EdgeMatches matches;
    bool checked = false;  ///< a pose-graph solve has judged the edge since it came
  };
  std::map<int64_t, Waiting> waiting_;  ///< matches of edges not in the tracks (yet)
  /// Matches of edges in the tracks, kept only to take them out again if the graph disables the edge.
  std::map<int64_t, PackedMatches> in_tracks_;
  GlobalBundleSchedule schedule_;     ///< which maps are due a global BA
  std::set<std::string> causes_;      ///< work done since the last result (logMoves)
  std::map<int64_t, SE3> published_;  ///< poses of the last result (logMoves)
  BundleAdjustmentStats counters_;
  int solves_skipped_ = 0;
  int merges_aligned_ = 0;
  bool graph_stale_ = false;  ///< neighbourhood solves since the last whole-graph one (due when quiet)
  int local_solves_ = 0;
  int local_refused_ = 0;
  SampleReservoir local_ms_, local_cpu_ms_;
};

}  // namespace rgbdmap
