#include "rgbdmap/backend/map_topology.hpp"

#include <cstdlib>
#include <set>

namespace rgbdmap {

void MapTopology::addEdge(const PoseGraphEdge& e) {
  edges_of_node_[e.from].push_back(e.id);
  edges_of_node_[e.to].push_back(e.id);
}

std::vector<std::pair<int64_t, int>> MapTopology::refresh(const PoseGraph& graph) {
  std::set<int64_t> fixed;
  for (const PoseGraphNode& n : graph.nodes())
    if (n.fixed) fixed.insert(n.id);
  anchor_of_.clear();
  std::vector<std::pair<int64_t, int>> moved;
  for (const std::vector<int64_t>& component : graph.components()) {
    const int map = static_cast<int>(component.front());
    int64_t anchor = component.front();
    for (int64_t id : component)
      if (fixed.count(id)) anchor = id;
    anchor_of_[map] = anchor;
    for (int64_t id : component) {
      auto [it, inserted] = map_of_.try_emplace(id, map);
      if (!inserted && it->second != map) {
        it->second = map;
        moved.emplace_back(id, map);
      }
    }
  }
  return moved;
}

int MapTopology::mapOf(int64_t id) const {
  const auto it = map_of_.find(id);
  return it == map_of_.end() ? 0 : it->second;
}

std::optional<int64_t> MapTopology::anchorOf(int map) const {
  const auto it = anchor_of_.find(map);
  if (it == anchor_of_.end()) return std::nullopt;
  return it->second;
}

const std::vector<int64_t>& MapTopology::edgesOf(int64_t id) const {
  static const std::vector<int64_t> kNone;
  const auto it = edges_of_node_.find(id);
  return it == edges_of_node_.end() ? kNone : it->second;
}

size_t MapTopology::keyframesIn(int map) const {
  size_t keyframes = 0;
  for (const auto& [id, m] : map_of_) keyframes += m == map;
  return keyframes;
}

std::vector<int64_t> MapTopology::odometryNeighbours(const PoseGraph& graph, int64_t id) const {
  std::vector<int64_t> out;
  for (int64_t e_id : edgesOf(id))
    if (const PoseGraphEdge* e = graph.edge(e_id); e && e->kind == EdgeKind::kOdometry)
      out.push_back(e->from == id ? e->to : e->from);
  return out;
}

bool MapTopology::isLargeCycle(const PoseGraphEdge& e, int loop_span) const {
  if (e.kind == EdgeKind::kOdometry) return false;
  if (chainOf(e.from) != chainOf(e.to)) return true;
  return std::abs(e.from - e.to) > loop_span;
}

}  // namespace rgbdmap
