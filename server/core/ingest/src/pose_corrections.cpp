#include "rgbdmap/ingest/pose_corrections.hpp"

#include <algorithm>
#include <set>

namespace rgbdmap {

std::map<std::string, msg::PoseCorrections> buildCorrections(
    const std::vector<IndexedNode>& nodes, const std::map<std::string, int64_t>& current_sessions,
    int64_t graph_revision) {
  std::map<std::string, msg::PoseCorrections> out;
  std::map<std::string, const IndexedNode*> newest;
  for (const IndexedNode& n : nodes) {
    const auto session = current_sessions.find(n.kf.robot_id);
    if (!n.valid || n.kf.session != (session == current_sessions.end() ? 0 : session->second)) continue;
    msg::PoseCorrections& c = out[n.kf.robot_id];
    c.robot_id = n.kf.robot_id;
    c.graph_revision = graph_revision;
    c.keyframes.push_back({n.kf.keyframe_id, n.kf.T_map_kf});
    newest[n.kf.robot_id] = &n;
  }
  for (auto& [robot, c] : out) {
    const IndexedNode& n = *newest[robot];
    c.T_map_odom = se3::normalized(n.kf.T_map_kf * n.kf.T_odom_kf.inverse());
    if (c.keyframes.size() > static_cast<size_t>(msg::kMaxCorrections))
      c.keyframes.erase(c.keyframes.begin(), c.keyframes.end() - msg::kMaxCorrections);
  }
  return out;
}

std::map<std::string, msg::LoopEdges> buildLoopEdges(const std::vector<IndexedNode>& nodes,
                                                     const std::vector<PoseGraphEdge>& edges,
                                                     const std::vector<int64_t>& disabled_edges,
                                                     const std::vector<std::string>& robots,
                                                     int64_t graph_revision, int max_edges) {
  const size_t cap = static_cast<size_t>(std::clamp(max_edges, 0, msg::kMaxLoopEdges));
  std::map<std::string, int> map_of;  // robot -> map id of its newest keyframe
  for (const IndexedNode& n : nodes)
    if (n.valid) map_of[n.kf.robot_id] = n.kf.map_id;
  std::map<int, std::vector<msg::MapLoopEdge>> of_map;  // the robots' maps, each list newest first
  for (const std::string& robot : robots)
    if (const auto it = map_of.find(robot); it != map_of.end()) of_map[it->second];
  const std::set<int64_t> disabled(disabled_edges.begin(), disabled_edges.end());
  auto valid = [&](int64_t id) {
    return id >= 0 && id < static_cast<int64_t>(nodes.size()) && nodes[id].valid;
  };
  size_t open = cap > 0 ? of_map.size() : 0;  // maps whose list is not full yet
  for (auto e = edges.rbegin(); e != edges.rend() && open > 0; ++e) {
    if (e->kind == EdgeKind::kOdometry || disabled.count(e->id) || !valid(e->from) || !valid(e->to)) continue;
    const ServerKeyframe& a = nodes[e->from].kf;
    const ServerKeyframe& b = nodes[e->to].kf;
    const auto list = of_map.find(a.map_id);
    if (list == of_map.end() || list->second.size() >= cap) continue;
    list->second.push_back({a.robot_id, a.keyframe_id, b.robot_id, b.keyframe_id,
                            e->kind == EdgeKind::kInterRobot, a.T_map_kf.translation(),
                            b.T_map_kf.translation()});
    if (list->second.size() == cap) --open;
  }
  for (auto& [map, list] : of_map) std::reverse(list.begin(), list.end());  // oldest first, as the graph
  std::map<std::string, msg::LoopEdges> out;
  for (const std::string& robot : robots) {
    msg::LoopEdges& m = out[robot];
    m.robot_id = robot;
    m.graph_revision = graph_revision;
    if (const auto map = map_of.find(robot); map != map_of.end()) m.edges = of_map.at(map->second);
  }
  return out;
}

}  // namespace rgbdmap
