// PoseGraph::optimizeLocal: the neighbourhood of new loop edges solved with the nodes around it held fixed.
#include <algorithm>
#include <chrono>
#include <deque>
#include <unordered_map>

#include "graph_internal.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_residual.hpp"

namespace rgbdmap {

using graph_detail::EdgeEnds;
using graph_detail::Pose7;

LocalOptimizeReport PoseGraph::optimizeLocal(const std::vector<int64_t>& edge_ids,
                                             const PoseGraphConfig& config, const std::atomic<bool>* cancel) {
  const auto t0 = std::chrono::steady_clock::now();
  LocalOptimizeReport report;
  const std::vector<bool> enabled = enabledMask();
  const std::vector<EdgeEnds>& ends = ends_;
  std::vector<std::vector<size_t>> edges_at(nodes_.size());  // enabled edges per node
  for (size_t k = 0; k < edges_.size(); ++k) {
    if (!enabled[k]) continue;
    edges_at[ends[k].from].push_back(k);
    edges_at[ends[k].to].push_back(k);
  }

  // The region: breadth-first from the seeds, at most local_max_nodes nodes.
  constexpr int kOutside = 0, kRegion = 1, kBoundary = 2;
  std::vector<char> role(nodes_.size(), kOutside);
  std::vector<size_t> region;
  std::deque<size_t> queue;
  const size_t max_nodes = static_cast<size_t>(std::max(1, config.local_max_nodes));
  std::vector<char> seed(edges_.size(), 0);
  for (int64_t id : edge_ids) {
    const auto it = edge_index_.find(id);
    if (it == edge_index_.end() || !enabled[it->second]) continue;
    seed[it->second] = 1;
    for (size_t i : {ends[it->second].from, ends[it->second].to}) {
      if (role[i] == kRegion || region.size() >= max_nodes) continue;
      role[i] = kRegion;
      region.push_back(i);
      queue.push_back(i);
    }
  }
  while (!queue.empty() && region.size() < max_nodes) {
    const size_t i = queue.front();
    queue.pop_front();
    for (size_t k : edges_at[i]) {
      const size_t j = ends[k].from == i ? ends[k].to : ends[k].from;
      if (role[j] == kRegion) continue;
      role[j] = kRegion;
      region.push_back(j);
      queue.push_back(j);
      if (region.size() >= max_nodes) break;
    }
  }
  if (region.empty()) return report;
  std::vector<size_t> boundary;
  for (size_t i : region)
    for (size_t k : edges_at[i]) {
      const size_t j = ends[k].from == i ? ends[k].to : ends[k].from;
      if (role[j] != kOutside) continue;
      role[j] = kBoundary;
      boundary.push_back(j);
    }
  report.region_nodes = static_cast<int>(region.size());
  report.boundary_nodes = static_cast<int>(boundary.size());
  if (boundary.empty()) {  // the whole component
    report.whole_component = true;
    return report;
  }

  // The sub-problem: region and boundary nodes, the enabled edges touching the region.
  const std::vector<bool> gauge = gaugeFixed(enabled);
  std::unordered_map<size_t, size_t> local_of;
  std::vector<size_t> global_of;
  std::vector<Pose7> params;
  std::vector<bool> fixed;
  for (const std::vector<size_t>* group : {&region, &boundary})
    for (size_t i : *group) {
      local_of.emplace(i, global_of.size());
      global_of.push_back(i);
      params.emplace_back();
      packPose(nodes_[i].T_map_kf, params.back().data());
      fixed.push_back(role[i] == kBoundary || gauge[i]);
    }
  std::vector<PoseGraphEdge> sub_edges;
  std::vector<Mat6> sub_sqrt;
  std::vector<EdgeEnds> sub_ends;
  std::vector<char> sub_seed, sub_fit_before;  // a seed edge; fits (chi2 <= outlier_chi2) at the start
  for (size_t k = 0; k < edges_.size(); ++k) {
    if (!enabled[k] || (role[ends[k].from] != kRegion && role[ends[k].to] != kRegion)) continue;
    sub_seed.push_back(seed[k]);
    sub_edges.push_back(edges_[k]);
    sub_sqrt.push_back(sqrt_information_[k]);
    sub_ends.push_back({local_of.at(ends[k].from), local_of.at(ends[k].to)});
  }
  report.edges = static_cast<int>(sub_edges.size());
  for (size_t k = 0; k < sub_edges.size(); ++k)
    sub_fit_before.push_back(graph_detail::edgeChi2(sub_edges[k], sub_sqrt[k], params[sub_ends[k].from],
                                                    params[sub_ends[k].to]) <= config.outlier_chi2);
  const std::vector<bool> sub_enabled(sub_edges.size(), true);
  auto solved = graph_detail::solveOnce(sub_edges, sub_sqrt, sub_ends, sub_enabled, fixed, config, cancel,
                                        &params, cg_tree_);
  if (solved.ok()) cg_tree_ = cg_tree_ || solved->tree_preconditioner;
  report.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (!solved.ok()) return report;
  report.iterations = solved->iterations;
  report.cancelled = solved->cancelled;
  report.out_of_time = solved->out_of_time;
  if (report.cancelled || report.out_of_time) return report;
  // Refused when a seed edge still does not fit, or an edge that fitted is strained past local_strain_chi2
  // (the region pulled against its fixed surroundings). Edges that did not fit before are the whole-graph
  // check's to judge; they do not count against the region.
  for (size_t k = 0; k < sub_edges.size(); ++k) {
    const double chi2 =
        graph_detail::edgeChi2(sub_edges[k], sub_sqrt[k], params[sub_ends[k].from], params[sub_ends[k].to]);
    if (sub_seed[k])
      report.worst_chi2 = std::max(report.worst_chi2, chi2);
    else if (sub_fit_before[k])
      report.worst_strain_chi2 = std::max(report.worst_strain_chi2, chi2);
  }
  if (!(report.worst_chi2 <= config.outlier_chi2 && report.worst_strain_chi2 <= config.local_strain_chi2))
    return report;
  report.accepted = true;
  for (size_t l = 0; l < region.size(); ++l) {
    nodes_[global_of[l]].T_map_kf = unpackPose(params[l].data());
    report.moved_nodes.push_back(nodes_[global_of[l]].id);
  }
  return report;
}

}  // namespace rgbdmap
