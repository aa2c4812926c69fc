#pragma once
// The map back-end's topology indices over its pose graph: each node's map (the first node of its connected
// component) and chain (PoseGraphNode::robot), each map's anchor (the node that holds its gauge), each node's
// edges. Rebuilt from the graph's components after additions and whole-graph solves.
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap {

class MapTopology {
 public:
  void addNode(int64_t id, int chain) { chain_of_[id] = chain; }
  void addEdge(const PoseGraphEdge& e);

  /// Map id and anchor of every node from `graph`'s components. Returns the nodes whose map changed (merged
  /// into another map, or split off), with their new map, in the order of the components.
  std::vector<std::pair<int64_t, int>> refresh(const PoseGraph& graph);

  bool contains(int64_t id) const { return map_of_.count(id) != 0; }  ///< the last refresh saw the node
  /// The map of a node (0 for a node the last refresh did not see).
  int mapOf(int64_t id) const;
  /// The node that holds the gauge of `map`.
  std::optional<int64_t> anchorOf(int map) const;
  int chainOf(int64_t id) const { return chain_of_.at(id); }
  /// Ids of the edges at a node.
  const std::vector<int64_t>& edgesOf(int64_t id) const;
  size_t keyframesIn(int map) const;  ///< keyframes of the map (a scan of every node)
  /// The nodes joined to `id` by an odometry edge of `graph`.
  std::vector<int64_t> odometryNeighbours(const PoseGraph& graph, int64_t id) const;
  /// A loop edge between two chains, or whose ends are more than `loop_span` keyframes apart.
  bool isLargeCycle(const PoseGraphEdge& e, int loop_span) const;

 private:
  std::map<int64_t, int> map_of_;                          ///< node -> map id (first node of its component)
  std::map<int, int64_t> anchor_of_;                       ///< map id -> the node that holds its gauge
  std::map<int64_t, int> chain_of_;                        ///< node -> its chain (PoseGraphNode::robot)
  std::map<int64_t, std::vector<int64_t>> edges_of_node_;  ///< node -> ids of its edges
};

}  // namespace rgbdmap
