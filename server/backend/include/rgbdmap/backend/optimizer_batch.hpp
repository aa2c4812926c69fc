#pragma once
// What the map back-end takes (OptimizerBatch: additions after a keyframe or a restore) and gives back
// (MapOptimization: every node's pose, disabled edges, components and the counters, after each batch).
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/backend/bundle_adjustment_stats.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_optimizer.hpp"

namespace rgbdmap {

/// What the ingest worker hands over after a keyframe (or a restore).
struct OptimizerBatch {
  std::vector<PoseGraphNode> nodes;         ///< new keyframes; a node with an odometry edge to a known
                                            ///< predecessor is placed by it, the others at their pose
  std::vector<PoseGraphEdge> edges;         ///< new odometry and loop edges
  std::vector<LandmarkKeyframe> keyframes;  ///< features of new keyframes, for bundle adjustment
  /// Rolling-shutter prior centres of keyframes added before (LandmarkMap::setRollingShutterPrior): once the
  /// step after a keyframe (or a split head's late step before it) came, the mean of its two steps, or the
  /// one it has (MapGraph::noteShutterStep).
  std::vector<std::pair<int64_t, Vec3>> w_priors;
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
    return nodes.empty() && edges.empty() && keyframes.empty() && w_priors.empty() && !solve && !must_solve &&
           !merge && !global;
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

}  // namespace rgbdmap
