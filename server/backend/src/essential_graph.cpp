#include "rgbdmap/backend/essential_graph.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <unordered_map>
#include <unordered_set>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

std::vector<CovisibleEdge> EssentialGraph::covisibleEdgeChanges(
    const std::vector<std::pair<int64_t, SE3>>& poses) const {
  std::unordered_map<int64_t, const SE3*> moved;
  for (const auto& [id, T] : poses) moved[id] = &T;
  const auto poseOf = [&](int64_t id) -> std::optional<SE3> {
    const auto it = moved.find(id);
    if (it != moved.end()) return *it->second;
    return graph_->pose(id);
  };
  const std::vector<int64_t>& disabled = graph_->disabledEdges();
  std::vector<CovisibleEdge> out;
  std::unordered_set<int64_t> seen;
  for (const auto& [id, T] : poses) {
    std::unordered_set<int64_t> shared;
    for (const auto& [other, n] : landmarks_->covisible(id)) shared.insert(other);
    for (int64_t e_id : topology_->edgesOf(id)) {
      const PoseGraphEdge* e = graph_->edge(e_id);
      if (!e || !shared.count(e->from == id ? e->to : e->from)) continue;
      if (std::binary_search(disabled.begin(), disabled.end(), e_id) || !seen.insert(e_id).second) continue;
      const std::optional<SE3> from = poseOf(e->from), to = poseOf(e->to);
      if (!from || !to) continue;
      const SE3 measured = from->inverse() * *to;
      const SE3 change = e->T_from_to.inverse() * measured;
      out.push_back({e, measured, change.translation().norm(), se3::rotationAngle(change) * 180.0 / M_PI});
    }
  }
  return out;
}

void EssentialGraph::apply(const BundleResult& r, std::vector<CovisibleEdge>* checked) {
  std::set<int64_t> in(r.moved.begin(), r.moved.end());
  in.insert(r.fixed.begin(), r.fixed.end());
  std::vector<std::pair<int64_t, SE3>> moved;
  for (int64_t id : r.moved) {
    graph_->setPose(id, *landmarks_->pose(id));
    moved.emplace_back(id, *landmarks_->pose(id));
  }
  const std::vector<CovisibleEdge> edges = checked ? std::move(*checked) : covisibleEdgeChanges(moved);
  int far = 0, far_odometry = 0;
  double far_t = 0.0, far_deg = 0.0;
  for (const CovisibleEdge& c : edges) {
    if (!in.count(c.edge->from) || !in.count(c.edge->to)) continue;
    if (c.t > 0.05 || c.deg > 2.0) {
      ++far;
      far_odometry += c.edge->kind == EdgeKind::kOdometry ? 1 : 0;
      far_t = std::max(far_t, c.t);
      far_deg = std::max(far_deg, c.deg);
    }
    graph_->setEdgeMeasurement(c.edge->id, c.measured);
  }
  if (far == 0) return;
  // Bundle adjustment moving edges is what it is for (drift taken out after a loop): info. Only a jump no
  // drift explains (a wrong loop, a broken track) is worth a warning.
  const bool suspicious = far_t > 0.5 || far_deg > 20.0;
  const std::string message = log::detail::concat(
      "optimiser: a bundle adjustment of ", r.report.frames, " keyframes",
      r.report.out_of_time ? " (out of time)" : "", " moved ", far, " edge measurements (", far_odometry,
      " odometry) by more than 5 cm or 2 deg, up to ", far_t, " m and ", far_deg, " deg");
  if (suspicious)
    log::warn(message);
  else
    log::info(message);
}

}  // namespace rgbdmap
