#include "pose_corrections.hpp"

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

}  // namespace rgbdmap
