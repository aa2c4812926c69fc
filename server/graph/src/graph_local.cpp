// PoseGraph::optimizeLocal: the neighbourhood of new loop edges solved with the nodes around it held fixed.
#include <algorithm>
#include <chrono>
#include <deque>
#include <unordered_map>
#include <utility>

#include "graph_internal.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_residual.hpp"

namespace rgbdmap {

using graph_detail::EdgeEnds;
using graph_detail::Pose7;

namespace {

constexpr int kOutside = 0, kRegion = 1, kBoundary = 2;  // a node's role in the local solve

size_t otherEnd(const EdgeEnds& ends, size_t i) { return ends.from == i ? ends.to : ends.from; }

/// The enabled edges (indices) at each node.
std::vector<std::vector<size_t>> enabledEdgesAt(size_t num_nodes, const std::vector<EdgeEnds>& ends,
                                                const std::vector<bool>& enabled) {
  std::vector<std::vector<size_t>> edges_at(num_nodes);
  for (size_t k = 0; k < ends.size(); ++k) {
    if (!enabled[k]) continue;
    edges_at[ends[k].from].push_back(k);
    edges_at[ends[k].to].push_back(k);
  }
  return edges_at;
}

/// The nodes solved (region), the fixed nodes around them (boundary), and each node's role.
struct LocalRegion {
  std::vector<char> role;
  std::vector<size_t> region;
  std::vector<size_t> boundary;
  std::vector<char> seed;  ///< per edge: one of the new loop edges
};

/// Marks the enabled seed edges and puts their end nodes into the region (at most max_nodes); returns
/// those nodes in the order to grow from.
std::deque<size_t> seedRegion(const std::vector<int64_t>& edge_ids,
                              const std::unordered_map<int64_t, size_t>& edge_index,
                              const std::vector<bool>& enabled, const std::vector<EdgeEnds>& ends,
                              size_t max_nodes, LocalRegion* r) {
  std::deque<size_t> queue;
  for (int64_t id : edge_ids) {
    const auto it = edge_index.find(id);
    if (it == edge_index.end() || !enabled[it->second]) continue;
    r->seed[it->second] = 1;
    for (size_t i : {ends[it->second].from, ends[it->second].to}) {
      if (r->role[i] == kRegion || r->region.size() >= max_nodes) continue;
      r->role[i] = kRegion;
      r->region.push_back(i);
      queue.push_back(i);
    }
  }
  return queue;
}

/// Grows the region breadth-first from `queue` until it holds max_nodes nodes or its component.
void growRegion(const std::vector<std::vector<size_t>>& edges_at, const std::vector<EdgeEnds>& ends,
                size_t max_nodes, std::deque<size_t> queue, LocalRegion* r) {
  while (!queue.empty() && r->region.size() < max_nodes) {
    const size_t i = queue.front();
    queue.pop_front();
    for (size_t k : edges_at[i]) {
      const size_t j = otherEnd(ends[k], i);
      if (r->role[j] == kRegion) continue;
      r->role[j] = kRegion;
      r->region.push_back(j);
      queue.push_back(j);
      if (r->region.size() >= max_nodes) break;
    }
  }
}

/// The nodes outside the region that an enabled edge ties to it.
void markBoundary(const std::vector<std::vector<size_t>>& edges_at, const std::vector<EdgeEnds>& ends,
                  LocalRegion* r) {
  for (size_t i : r->region)
    for (size_t k : edges_at[i]) {
      const size_t j = otherEnd(ends[k], i);
      if (r->role[j] != kOutside) continue;
      r->role[j] = kBoundary;
      r->boundary.push_back(j);
    }
}

/// The sub-problem: region and boundary nodes (region first), the enabled edges touching the region.
struct LocalProblem {
  std::unordered_map<size_t, size_t> local_of;
  std::vector<size_t> global_of;
  std::vector<Pose7> params;
  std::vector<bool> fixed;
  std::vector<PoseGraphEdge> edges;
  std::vector<Mat6> sqrt_info;
  std::vector<EdgeEnds> ends;
  std::vector<char> seed, fit_before;  ///< a seed edge; fits (chi2 <= outlier_chi2) at the start

  double chi2(size_t k) const {
    return graph_detail::edgeChi2(edges[k], sqrt_info[k], params[ends[k].from], params[ends[k].to]);
  }
};

void addLocalNodes(const LocalRegion& r, const std::vector<PoseGraphNode>& nodes,
                   const std::vector<bool>& gauge, LocalProblem* sub) {
  for (const std::vector<size_t>* group : {&r.region, &r.boundary})
    for (size_t i : *group) {
      sub->local_of.emplace(i, sub->global_of.size());
      sub->global_of.push_back(i);
      sub->params.emplace_back();
      packPose(nodes[i].T_map_kf, sub->params.back().data());
      sub->fixed.push_back(r.role[i] == kBoundary || gauge[i]);
    }
}

void addLocalEdges(const LocalRegion& r, const std::vector<PoseGraphEdge>& edges,
                   const std::vector<Mat6>& sqrt_information, const std::vector<EdgeEnds>& ends,
                   const std::vector<bool>& enabled, LocalProblem* sub) {
  for (size_t k = 0; k < edges.size(); ++k) {
    if (!enabled[k] || (r.role[ends[k].from] != kRegion && r.role[ends[k].to] != kRegion)) continue;
    sub->seed.push_back(r.seed[k]);
    sub->edges.push_back(edges[k]);
    sub->sqrt_info.push_back(sqrt_information[k]);
    sub->ends.push_back({sub->local_of.at(ends[k].from), sub->local_of.at(ends[k].to)});
  }
}

/// The worst seed edge and the worst edge that fitted before, at the solved poses. Edges that did not fit
/// before are the whole-graph check's to judge; they do not count against the region.
void measureFit(const LocalProblem& sub, LocalOptimizeReport* report) {
  for (size_t k = 0; k < sub.edges.size(); ++k) {
    const double chi2 = sub.chi2(k);
    if (sub.seed[k])
      report->worst_chi2 = std::max(report->worst_chi2, chi2);
    else if (sub.fit_before[k])
      report->worst_strain_chi2 = std::max(report->worst_strain_chi2, chi2);
  }
}

}  // namespace

LocalOptimizeReport PoseGraph::optimizeLocal(const std::vector<int64_t>& edge_ids,
                                             const PoseGraphConfig& config, const std::atomic<bool>* cancel) {
  const auto t0 = std::chrono::steady_clock::now();
  LocalOptimizeReport report;
  const std::vector<bool> enabled = enabledMask();
  const std::vector<std::vector<size_t>> edges_at = enabledEdgesAt(nodes_.size(), ends_, enabled);

  // The region: breadth-first from the seeds, at most local_max_nodes nodes.
  LocalRegion r;
  r.role.assign(nodes_.size(), kOutside);
  const size_t max_nodes = static_cast<size_t>(std::max(1, config.local_max_nodes));
  r.seed.assign(edges_.size(), 0);
  std::deque<size_t> queue = seedRegion(edge_ids, edge_index_, enabled, ends_, max_nodes, &r);
  growRegion(edges_at, ends_, max_nodes, std::move(queue), &r);
  if (r.region.empty()) return report;
  markBoundary(edges_at, ends_, &r);
  report.region_nodes = static_cast<int>(r.region.size());
  report.boundary_nodes = static_cast<int>(r.boundary.size());
  if (r.boundary.empty()) {  // the whole component
    report.whole_component = true;
    return report;
  }

  const std::vector<bool> gauge = gaugeFixed(enabled);
  LocalProblem sub;
  addLocalNodes(r, nodes_, gauge, &sub);
  addLocalEdges(r, edges_, sqrt_information_, ends_, enabled, &sub);
  report.edges = static_cast<int>(sub.edges.size());
  for (size_t k = 0; k < sub.edges.size(); ++k) sub.fit_before.push_back(sub.chi2(k) <= config.outlier_chi2);
  const std::vector<bool> sub_enabled(sub.edges.size(), true);
  auto solved = graph_detail::solveOnce(sub.edges, sub.sqrt_info, sub.ends, sub_enabled, sub.fixed, config,
                                        cancel, &sub.params, cg_tree_);
  if (solved.ok()) cg_tree_ = cg_tree_ || solved->tree_preconditioner;
  report.time_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (!solved.ok()) return report;
  report.iterations = solved->iterations;
  report.cancelled = solved->cancelled;
  report.out_of_time = solved->out_of_time;
  if (report.cancelled || report.out_of_time) return report;
  // Refused when a seed edge still does not fit, or an edge that fitted is strained past local_strain_chi2
  // (the region pulled against its fixed surroundings).
  measureFit(sub, &report);
  if (!(report.worst_chi2 <= config.outlier_chi2 && report.worst_strain_chi2 <= config.local_strain_chi2))
    return report;
  report.accepted = true;
  for (size_t l = 0; l < r.region.size(); ++l) {
    nodes_[sub.global_of[l]].T_map_kf = unpackPose(sub.params[l].data());
    report.moved_nodes.push_back(nodes_[sub.global_of[l]].id);
  }
  return report;
}

}  // namespace rgbdmap
