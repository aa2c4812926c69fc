#include "pose_corrections.hpp"

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
                                                     int64_t graph_revision) {
  std::map<std::string, int> map_of;  // robot -> map id of its newest keyframe
  for (const IndexedNode& n : nodes)
    if (n.valid) map_of[n.kf.robot_id] = n.kf.map_id;
  const std::set<int64_t> disabled(disabled_edges.begin(), disabled_edges.end());
  auto valid = [&](int64_t id) {
    return id >= 0 && id < static_cast<int64_t>(nodes.size()) && nodes[id].valid;
  };
  std::map<std::string, msg::LoopEdges> out;
  for (const std::string& robot : robots) {
    msg::LoopEdges& m = out[robot];
    m.robot_id = robot;
    m.graph_revision = graph_revision;
    const auto map = map_of.find(robot);
    if (map == map_of.end()) continue;
    for (const PoseGraphEdge& e : edges) {
      if (e.kind == EdgeKind::kOdometry || disabled.count(e.id) || !valid(e.from) || !valid(e.to)) continue;
      const ServerKeyframe& a = nodes[e.from].kf;
      const ServerKeyframe& b = nodes[e.to].kf;
      if (a.map_id != map->second) continue;
      m.edges.push_back({a.robot_id, a.keyframe_id, b.robot_id, b.keyframe_id,
                         e.kind == EdgeKind::kInterRobot, a.T_map_kf.translation(),
                         b.T_map_kf.translation()});
    }
    if (m.edges.size() > static_cast<size_t>(msg::kMaxLoopEdges))
      m.edges.erase(m.edges.begin(), m.edges.end() - msg::kMaxLoopEdges);
  }
  return out;
}

}  // namespace rgbdmap
