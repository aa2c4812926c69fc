#pragma once
// What each robot is told after an optimisation: a pure function of the keyframes' optimised poses.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/ingest/keyframe_index.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

/// PoseCorrections for each robot's current process. `nodes` in node id order (invalid ones are skipped);
/// `current_sessions`: robot -> the session of its running process (a robot missing from it has session 0).
/// A robot's corrections carry its current session's keyframes with their optimised T_map_kf (the newest
/// msg::kMaxCorrections of them) and T_map_odom of its newest keyframe (T_map_kf * T_odom_kf^-1). Robots
/// with no keyframe of their current session get nothing.
std::map<std::string, msg::PoseCorrections> buildCorrections(
    const std::vector<IndexedNode>& nodes, const std::map<std::string, int64_t>& current_sessions,
    int64_t graph_revision);

/// LoopEdges for each robot in `robots`: the enabled loop and inter-robot edges of `edges` whose first
/// keyframe is in the map (graph component) of the robot's newest keyframe, with both ends' optimised
/// positions. `nodes` indexed by node id; at most `max_edges` (and msg::kMaxLoopEdges) per robot, the newest.
/// Each map's list is made once for all its robots, walking the edges from the newest: O(max_edges) per
/// map while its edges are dense, never O(edges x robots).
std::map<std::string, msg::LoopEdges> buildLoopEdges(const std::vector<IndexedNode>& nodes,
                                                     const std::vector<PoseGraphEdge>& edges,
                                                     const std::vector<int64_t>& disabled_edges,
                                                     const std::vector<std::string>& robots,
                                                     int64_t graph_revision,
                                                     int max_edges = msg::kMaxLoopEdges);

}  // namespace rgbdmap
