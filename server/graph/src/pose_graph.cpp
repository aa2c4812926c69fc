#include "rgbdmap/graph/pose_graph.hpp"

#include <algorithm>
#include <chrono>
#include <string>

#include "graph_internal.hpp"
#include "rgbdmap/graph/pose_graph_residual.hpp"

namespace rgbdmap {

using graph_detail::EdgeEnds;
using graph_detail::Pose7;

const char* toString(EdgeKind kind) {
  switch (kind) {
    case EdgeKind::kOdometry:
      return "odometry";
    case EdgeKind::kLoop:
      return "loop";
    case EdgeKind::kInterRobot:
      return "inter_robot";
  }
  return "unknown";
}

Status PoseGraph::addNode(int64_t id, int robot, const SE3& T_map_kf) {
  if (node_index_.count(id)) return Status::failure("duplicate node id " + std::to_string(id));
  if (!se3::isValid(T_map_kf, 1e-4)) return Status::failure("invalid pose for node " + std::to_string(id));
  node_index_[id] = nodes_.size();
  nodes_.push_back({id, robot, se3::normalized(T_map_kf), false});
  incident_.emplace_back();
  return Status::success();
}

Status PoseGraph::addEdge(const PoseGraphEdge& edge) {
  const std::string name = "edge " + std::to_string(edge.id);
  if (edge_index_.count(edge.id)) return Status::failure("duplicate " + name);
  if (!node_index_.count(edge.from) || !node_index_.count(edge.to)) {
    return Status::failure(name + " refers to an unknown node");
  }
  if (edge.from == edge.to) return Status::failure(name + " connects a node to itself");
  if (!se3::isValid(edge.T_from_to, 1e-4)) return Status::failure(name + " has an invalid pose");
  const Mat6& info = edge.information;
  if (!info.allFinite() || !info.isApprox(info.transpose(), 1e-9)) {
    return Status::failure(name + " has a non-finite or asymmetric information matrix");
  }
  Mat6 sqrt_info;
  if (!sqrtInformation(residualInformation(edge.T_from_to, info), &sqrt_info)) {
    return Status::failure(name + " has an information matrix that is not positive definite");
  }
  const auto k = static_cast<uint32_t>(edges_.size());
  edge_index_[edge.id] = k;
  const auto from = static_cast<uint32_t>(node_index_.at(edge.from));
  const auto to = static_cast<uint32_t>(node_index_.at(edge.to));
  incident_[from].push_back({k, to, true});
  incident_[to].push_back({k, from, false});
  ends_.push_back({from, to});
  edges_.push_back(edge);
  edges_.back().T_from_to = se3::normalized(edge.T_from_to);
  sqrt_information_.push_back(sqrt_info);
  return Status::success();
}

Status PoseGraph::setFixed(int64_t id, bool fixed) {
  const auto it = node_index_.find(id);
  if (it == node_index_.end()) return Status::failure("unknown node " + std::to_string(id));
  nodes_[it->second].fixed = fixed;
  return Status::success();
}

Status PoseGraph::setPose(int64_t id, const SE3& T_map_kf) {
  const auto it = node_index_.find(id);
  if (it == node_index_.end()) return Status::failure("unknown node " + std::to_string(id));
  if (!se3::isValid(T_map_kf, 1e-4)) return Status::failure("invalid pose for node " + std::to_string(id));
  nodes_[it->second].T_map_kf = se3::normalized(T_map_kf);
  return Status::success();
}

Status PoseGraph::setEdgeMeasurement(int64_t id, const SE3& T_from_to) {
  const auto it = edge_index_.find(id);
  if (it == edge_index_.end()) return Status::failure("unknown edge " + std::to_string(id));
  if (!se3::isValid(T_from_to, 1e-4)) return Status::failure("invalid pose for edge " + std::to_string(id));
  PoseGraphEdge& e = edges_[it->second];
  Mat6 sqrt_info;
  if (!sqrtInformation(residualInformation(T_from_to, e.information), &sqrt_info))
    return Status::failure("edge " + std::to_string(id) + ": information not positive definite");
  e.T_from_to = se3::normalized(T_from_to);
  sqrt_information_[it->second] = sqrt_info;
  return Status::success();
}

const PoseGraphEdge* PoseGraph::edge(int64_t id) const {
  const auto it = edge_index_.find(id);
  return it == edge_index_.end() ? nullptr : &edges_[it->second];
}

std::optional<SE3> PoseGraph::pose(int64_t id) const {
  const auto it = node_index_.find(id);
  if (it == node_index_.end()) return std::nullopt;
  return nodes_[it->second].T_map_kf;
}

std::map<int64_t, SE3> PoseGraph::poses() const {
  std::map<int64_t, SE3> out;
  for (const auto& n : nodes_) out.emplace(n.id, n.T_map_kf);
  return out;
}

int PoseGraph::applyOptimized(const std::map<int64_t, SE3>& T_map_kf,
                              const std::vector<int64_t>& disabled_edge_ids) {
  std::unordered_map<int, SE3> correction_of_robot;  // T_map_new * T_map_old^-1 of the robot's latest node
  int corrected = 0;
  for (auto& node : nodes_) {
    const auto it = T_map_kf.find(node.id);
    if (it != T_map_kf.end()) {
      correction_of_robot[node.robot] = it->second * node.T_map_kf.inverse();
      node.T_map_kf = it->second;
    } else if (const auto c = correction_of_robot.find(node.robot); c != correction_of_robot.end()) {
      node.T_map_kf = se3::normalized(c->second * node.T_map_kf);
      ++corrected;
    }
  }
  disabled_edges_.clear();
  for (int64_t id : disabled_edge_ids) {
    if (edge_index_.count(id)) disabled_edges_.push_back(id);
  }
  std::sort(disabled_edges_.begin(), disabled_edges_.end());
  return corrected;
}

std::optional<double> PoseGraph::edgeChi2(int64_t id) const {
  const auto it = edge_index_.find(id);
  if (it == edge_index_.end()) return std::nullopt;
  const PoseGraphEdge& e = edges_[it->second];
  Pose7 from{}, to{};
  packPose(nodes_[node_index_.at(e.from)].T_map_kf, from.data());
  packPose(nodes_[node_index_.at(e.to)].T_map_kf, to.data());
  return graph_detail::edgeChi2(e, sqrt_information_[it->second], from, to);
}

namespace {
bool isLoop(const PoseGraphEdge& e) { return e.kind != EdgeKind::kOdometry; }
}  // namespace

std::unordered_map<int64_t, SE3> PoseGraph::measuredPosesNear(int64_t source, int max_hops,
                                                              size_t max_nodes) const {
  std::unordered_map<int64_t, SE3> out;
  const auto it = node_index_.find(source);
  if (it == node_index_.end() || max_nodes == 0) return out;
  // Breadth first over enabled edges: each node is reached by a path of fewest hops, and its pose relative
  // to the source is the product of that path's measurements (T_from_to = T_map_from^-1 T_map_to). Paths
  // are short, so the products are not re-normalised.
  std::vector<char> seen(nodes_.size(), 0);
  std::vector<std::pair<uint32_t, SE3>> reached;  // node index, T_source_node; in BFS order
  reached.reserve(std::min(max_nodes, nodes_.size()));
  reached.emplace_back(static_cast<uint32_t>(it->second), SE3::Identity());
  seen[it->second] = 1;
  size_t begin = 0;  // the current hop's nodes are reached[begin, end)
  for (int hop = 0; hop < max_hops && reached.size() < max_nodes; ++hop) {
    const size_t end = reached.size();
    if (begin == end) break;
    for (size_t r = begin; r < end && reached.size() < max_nodes; ++r) {
      const uint32_t i = reached[r].first;
      for (const Incidence& inc : incident_[i]) {
        if (seen[inc.other] ||
            std::binary_search(disabled_edges_.begin(), disabled_edges_.end(), edges_[inc.edge].id))
          continue;
        seen[inc.other] = 1;
        const SE3& T = edges_[inc.edge].T_from_to;
        reached.emplace_back(inc.other, reached[r].second * (inc.forward ? T : T.inverse()));
        if (reached.size() >= max_nodes) break;
      }
    }
    begin = end;
  }
  out.reserve(reached.size());
  for (const auto& [i, T] : reached) out.emplace(nodes_[i].id, T);
  return out;
}

std::vector<bool> PoseGraph::enabledMask() const {
  std::vector<bool> enabled(edges_.size(), true);
  for (int64_t id : disabled_edges_) enabled[edge_index_.at(id)] = false;
  return enabled;
}

std::vector<std::vector<int64_t>> PoseGraph::components() const {
  const auto labels = graph_detail::componentLabels(nodes_.size(), ends_, enabledMask());
  std::vector<std::vector<int64_t>> groups;
  std::unordered_map<size_t, size_t> group_of_label;
  for (size_t i = 0; i < nodes_.size(); ++i) {
    const auto [it, inserted] = group_of_label.emplace(labels[i], groups.size());
    if (inserted) groups.emplace_back();
    groups[it->second].push_back(nodes_[i].id);
  }
  return groups;
}

std::vector<bool> PoseGraph::gaugeFixed(const std::vector<bool>& enabled) const {
  const auto labels = graph_detail::componentLabels(nodes_.size(), ends_, enabled);
  std::vector<bool> fixed(nodes_.size(), false);
  std::vector<bool> label_has_fixed(nodes_.size(), false);
  for (size_t i = 0; i < nodes_.size(); ++i) {
    fixed[i] = nodes_[i].fixed;
    if (fixed[i]) label_has_fixed[labels[i]] = true;
  }
  // The label is the smallest member index, i.e. the component's first-added node.
  for (size_t i = 0; i < nodes_.size(); ++i) {
    if (!label_has_fixed[labels[i]]) fixed[labels[i]] = true;
  }
  return fixed;
}

PoseGraph::Alignment PoseGraph::alignSubmaps(const PoseGraphConfig& config) {
  const std::vector<EdgeEnds>& ends = ends_;
  const std::vector<bool> enabled = enabledMask();
  std::vector<SE3> T_map_kf;
  T_map_kf.reserve(nodes_.size());
  for (const auto& n : nodes_) T_map_kf.push_back(n.T_map_kf);
  std::vector<long> moved_by;
  Alignment out;
  if (graph_detail::alignSubmaps(edges_, ends, enabled, gaugeFixed(enabled), config, &T_map_kf, &moved_by) ==
      0)
    return out;
  for (size_t i = 0; i < nodes_.size(); ++i) {
    if (moved_by[i] < 0) continue;
    nodes_[i].T_map_kf = T_map_kf[i];
    out.moved_nodes.push_back(nodes_[i].id);
  }
  for (size_t k = 0; k < edges_.size(); ++k)
    if (enabled[k] && moved_by[ends[k].from] != moved_by[ends[k].to])
      out.changed_edges.push_back(edges_[k].id);
  return out;
}

Result<OptimizeReport> PoseGraph::optimize(const PoseGraphConfig& config, const std::atomic<bool>* cancel) {
  const auto t0 = std::chrono::steady_clock::now();
  OptimizeReport report;
  const std::vector<EdgeEnds>& ends = ends_;
  std::vector<bool> enabled = enabledMask();
  for (const auto& e : edges_) report.loops_total += isLoop(e) ? 1 : 0;

  std::vector<SE3> T_map_kf;
  for (const auto& n : nodes_) T_map_kf.push_back(n.T_map_kf);
  report.merged_submaps =
      graph_detail::alignSubmaps(edges_, ends, enabled, gaugeFixed(enabled), config, &T_map_kf);
  std::vector<Pose7> params(nodes_.size());
  for (size_t i = 0; i < nodes_.size(); ++i) packPose(T_map_kf[i], params[i].data());

  for (int round = 0; round <= std::max(0, config.max_outlier_rounds); ++round) {
    auto solved = graph_detail::solveOnce(edges_, sqrt_information_, ends, enabled, gaugeFixed(enabled),
                                          config, cancel, &params, cg_tree_);
    if (!solved.ok()) return Result<OptimizeReport>::failure(solved.error());
    cg_tree_ = cg_tree_ || solved->tree_preconditioner;
    if (report.solves++ == 0) report.initial_cost = solved->initial_cost;
    report.iterations += solved->iterations;
    report.final_cost = solved->final_cost;
    report.cancelled = solved->cancelled;
    report.out_of_time = report.out_of_time || solved->out_of_time;
    report.iteration_limit =
        report.iteration_limit || (!solved->converged && !solved->out_of_time && !solved->cancelled);
    report.tree_preconditioned_solves += solved->tree_preconditioner ? 1 : 0;
    // An unfinished solve is no basis for disabling loops: on a loaded machine it would reject true ones,
    // and one stopped by its iteration limit may be as far from the optimum.
    if (report.cancelled || !solved->converged || round == config.max_outlier_rounds) break;
    const std::vector<bool> next =
        graph_detail::consistentEdges(edges_, sqrt_information_, ends, params, enabled, config.outlier_chi2);
    if (next == enabled) break;
    enabled = next;
  }
  if (report.cancelled) return report;  // keep the previous poses and disabled set

  for (size_t i = 0; i < nodes_.size(); ++i) nodes_[i].T_map_kf = unpackPose(params[i].data());
  disabled_edges_.clear();
  for (size_t k = 0; k < edges_.size(); ++k) {
    if (!enabled[k]) disabled_edges_.push_back(edges_[k].id);
  }
  std::sort(disabled_edges_.begin(), disabled_edges_.end());
  report.loops_rejected = static_cast<int>(disabled_edges_.size());
  report.rejected_edge_ids = disabled_edges_;
  report.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace rgbdmap
