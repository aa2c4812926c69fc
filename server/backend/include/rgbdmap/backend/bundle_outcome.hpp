#pragma once
// The check of a bundle adjustment's outcome before anything is applied, its counting after, and the
// relative-pose priors a global BA takes from the pose graph:
//   - check: an outcome that changes the relative pose of two keyframes sharing landmarks (an edge between
//     them) by more than max_edge_change_m / _deg is refused; the covisible edges it found are kept for the
//     edge rewrite (EssentialGraph::apply) of that same outcome;
//   - count: refused adjustments, parts kept in place;
//   - step priors: the enabled edges of a map whose keyframes share too few landmarks for a BA to know their
//     relative pose (BundleAdjustmentConfig::global_step_priors).
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/backend/bundle_adjustment_config.hpp"
#include "rgbdmap/backend/bundle_adjustment_stats.hpp"
#include "rgbdmap/backend/essential_graph.hpp"
#include "rgbdmap/backend/map_topology.hpp"
#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap {

class BundleOutcome {
 public:
  BundleOutcome(const BundleAdjustmentConfig* config, const PoseGraph* graph, const LandmarkMap* landmarks,
                const MapTopology* topology, const EssentialGraph* essential)
      : config_(config), graph_(graph), landmarks_(landmarks), topology_(topology), essential_(essential) {}

  /// Why the outcome that moves the keyframes to `proposed` is refused ("" when it is not).
  std::string check(const std::vector<std::pair<int64_t, SE3>>& proposed);
  /// The covisible edges check() found, when the outcome it saw last moved exactly `moved` (null otherwise);
  /// valid until the next check() or forget().
  std::vector<CovisibleEdge>* checkedEdges(const std::vector<int64_t>& moved);
  void forget() { checked_ = {}; }

  /// Counts a finished adjustment (refused, parts kept) into `counters`; true when it is to be applied.
  static bool count(const BundleResult& r, const char* kind, BundleAdjustmentStats* counters);

  /// The enabled edges of `map` whose keyframes share fewer than landmarks.min_covisibility landmarks, as
  /// priors for its global BA (none unless global_step_priors).
  std::vector<BundlePrior> stepPriors(int map) const;

 private:
  const BundleAdjustmentConfig* config_;
  const PoseGraph* graph_;
  const LandmarkMap* landmarks_;
  const MapTopology* topology_;
  const EssentialGraph* essential_;
  struct {
    std::vector<int64_t> moved;        ///< the keyframes of the outcome check() saw last
    std::vector<CovisibleEdge> edges;  ///< its covisible edges
  } checked_;
};

}  // namespace rgbdmap
