#pragma once
// The essential-graph edge rewrite: after a bundle adjustment, the enabled edges between keyframes it refined
// that share landmarks take the refined relative poses as their measurements (ORB-SLAM's essential graph), so
// a later pose-graph solve spreads a loop's correction without undoing the refinement. An edge whose
// keyframes share no landmarks (an odometry step into a room not seen before) keeps its measurement: the
// adjustment knows nothing of that relative pose.
#include <cstdint>
#include <utility>
#include <vector>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/backend/map_topology.hpp"
#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap {

/// An enabled edge at a keyframe of an adjustment whose two keyframes share landmarks: the relative pose the
/// adjustment's poses give it, and how far that is from its measurement.
struct CovisibleEdge {
  const PoseGraphEdge* edge;
  SE3 measured;
  double t, deg;
};

class EssentialGraph {
 public:
  EssentialGraph(PoseGraph* graph, const LandmarkMap* landmarks, const MapTopology* topology)
      : graph_(graph), landmarks_(landmarks), topology_(topology) {}

  /// The covisible edges at the keyframes of `poses` (their new poses; the graph's for the other end), once.
  std::vector<CovisibleEdge> covisibleEdgeChanges(const std::vector<std::pair<int64_t, SE3>>& poses) const;
  /// Applies an adjustment: its moved keyframes take the landmark map's poses, and the covisible edges whose
  /// two keyframes it saw take their relative poses. `checked`: the covisible edges its check found (null:
  /// found here). Logs (warn) measurements moved by more than 5 cm or 2 deg.
  void apply(const BundleResult& r, std::vector<CovisibleEdge>* checked);

 private:
  PoseGraph* graph_;
  const LandmarkMap* landmarks_;
  const MapTopology* topology_;
};

}  // namespace rgbdmap
