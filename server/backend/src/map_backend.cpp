// MapBackend: a batch -> pose graph (additions, robust solve) -> landmark tracks (matches of kept edges)
// -> local and global bundle adjustment -> refined edges -> one result.
#include "rgbdmap/backend/map_backend.hpp"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <utility>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {
namespace {

/// CPU time of the calling thread (ms).
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

MapBackend::MapBackend(MapBackendConfig config)
    : config_(std::move(config)),
      landmarks_(config_.ba.landmarks),
      schedule_({config_.ba.global_every_keyframes, config_.ba.global_min_growth_fraction,
                 config_.ba.global_max_keyframes}) {
  if (config_.features) landmarks_.setFeatureCache(config_.features);
}

std::shared_ptr<MapOptimization> MapBackend::runBatch(const OptimizerBatch& b) {
  applyAdditions(b);
  OptimizedPoses solve;
  std::vector<int64_t> seeds;  // the edges a solve must reconcile; none: the whole graph
  bool solved = b.solve && needsSolve(b, &seeds) && solveGraph(&solve, seeds);
  // Asked for the global refinement (waitIdle): the whole graph after neighbourhood solves, then the BA.
  if (b.global && graph_stale_ && !solved) solved = solveGraph(&solve);
  bool chains_joined = false;
  const bool large_cycle = updateTracks(&chains_joined);
  if (config_.ba.enabled) {
    std::vector<int64_t> ids;
    for (const LandmarkKeyframe& k : b.keyframes) ids.push_back(k.id);
    adjustNewKeyframes(ids);
    adjustGlobally(schedule_.dueAfterBatch(b.global, large_cycle || chains_joined,
                                           [this](int map) { return topology_.keyframesIn(map); }));
  }
  if (cancel_) return nullptr;
  return result(solved, solve);
}

std::shared_ptr<MapOptimization> MapBackend::runIdle() {
  OptimizedPoses solve;
  const bool solved = graph_stale_ && solveGraph(&solve);
  if (config_.ba.enabled) adjustGlobally(schedule_.changed());
  if (cancel_) return nullptr;
  return result(solved, solve);
}

bool MapBackend::globalDue() const {
  return (config_.ba.enabled && !schedule_.changed().empty()) || graph_stale_;
}

void MapBackend::applyAdditions(const OptimizerBatch& b) {
  std::map<int64_t, const PoseGraphEdge*> odometry_from;  // a new node's odometry edge to its predecessor
  for (const PoseGraphEdge& e : b.edges)
    if (e.kind == EdgeKind::kOdometry) odometry_from.emplace(e.from, &e);
  for (const PoseGraphNode& n : b.nodes) {
    SE3 pose = n.T_map_kf;  // chained from the predecessor's current pose when it is known here
    if (const auto it = odometry_from.find(n.id); it != odometry_from.end())
      if (const auto prev = graph_.pose(it->second->to))
        pose = se3::normalized(*prev * it->second->T_from_to.inverse());
    if (const Status s = graph_.addNode(n.id, n.robot, pose); !s) {
      log::warn("optimiser: ", s.error());
      continue;
    }
    if (n.fixed) graph_.setFixed(n.id);
    topology_.addNode(n.id, n.robot);
  }
  for (const PoseGraphEdge& e : b.edges) {
    if (const Status s = graph_.addEdge(e); !s) {
      log::warn("optimiser: ", s.error());
      continue;
    }
    topology_.addEdge(e);
  }
  for (const auto& [id, m] : b.matches) waiting_[id] = {m, false};
  refreshMaps();
  for (const LandmarkKeyframe& k : b.keyframes) {
    const auto pose = graph_.pose(k.id);
    if (!pose || !config_.ba.enabled) continue;
    LandmarkKeyframe kf = k;
    kf.T_map_kf = *pose;
    kf.map_id = topology_.mapOf(k.id);
    if (const Status s = landmarks_.addKeyframe(std::move(kf)); !s) log::warn("optimiser: ", s.error());
  }
  for (const auto& [id, w_prior] : b.w_priors) landmarks_.setRollingShutterPrior(id, w_prior);
}

void MapBackend::refreshMaps() {
  // Merged (or split off): landmarks follow their keyframes, new to their map's global BA.
  for (const auto& [id, map] : topology_.refresh(graph_)) {
    schedule_.keyframeAdded(map);
    landmarks_.setPose(id, map, *graph_.pose(id));
  }
}

bool MapBackend::solveGraph(OptimizedPoses* out, const std::vector<int64_t>& seeds) {
  if (!seeds.empty() && config_.graph.local_max_nodes > 0) {
    const LocalOptimizeReport local = graph_.optimizeLocal(seeds, config_.graph, &cancel_);
    if (local.cancelled) return false;
    if (local.accepted) {
      ++local_solves_;
      causes_.insert("local solve");
      graph_stale_ = true;
      out->report.solves = 1;
      out->report.iterations = local.iterations;
      out->report.time_ms = local.time_ms;
      // The edges that fit now are judged as a converged solve would judge them; the others wait for one.
      for (auto& [id, w] : waiting_)
        if (const auto chi2 = graph_.edgeChi2(id); chi2 && *chi2 <= config_.graph.outlier_chi2)
          w.checked = true;
      for (int64_t id : local.moved_nodes) landmarks_.setPose(id, topology_.mapOf(id), *graph_.pose(id));
      return true;
    }
    if (!local.whole_component) {
      ++local_refused_;
      log::debug("optimiser: local solve of ", local.region_nodes, " nodes refused (worst chi2 ",
                 local.worst_chi2, ", strain chi2 ", local.worst_strain_chi2,
                 local.out_of_time ? ", out of time" : "", "): solving the whole graph");
    }
  }
  const Result<OptimizeReport> report = graph_.optimize(config_.graph, &cancel_);
  if (!report || report->cancelled) {
    if (!cancel_) log::warn("optimiser: pose graph: ", report ? "cancelled" : report.error());
    return false;
  }
  out->report = *report;
  causes_.insert("whole-graph solve");
  graph_stale_ = false;
  for (auto& [id, w] : waiting_) w.checked = true;  // the solve judged every edge added so far
  refreshMaps();
  for (const PoseGraphNode& n : graph_.nodes()) landmarks_.setPose(n.id, topology_.mapOf(n.id), n.T_map_kf);
  return true;
}

bool MapBackend::needsSolve(const OptimizerBatch& b, std::vector<int64_t>* seeds) {
  const double limit = config_.graph.solve_above_chi2;
  if (b.must_solve || limit <= 0.0) return true;
  std::vector<int64_t> check;  // edges a solve would have to reconcile
  if (b.merge) {
    const PoseGraph::Alignment moved = graph_.alignSubmaps(config_.graph);
    for (int64_t id : moved.moved_nodes) landmarks_.setPose(id, topology_.mapOf(id), *graph_.pose(id));
    check = moved.changed_edges;
    merges_aligned_ += moved.moved_nodes.empty() ? 0 : 1;
    if (!moved.moved_nodes.empty()) causes_.insert("merge");
  }
  std::vector<int64_t> loops;
  for (const PoseGraphEdge& e : b.edges) {
    if (e.kind == EdgeKind::kOdometry) continue;
    check.push_back(e.id);
    loops.push_back(e.id);
  }
  for (int64_t id : check) {
    const std::optional<double> chi2 = graph_.edgeChi2(id);
    if (!chi2 || *chi2 > limit) {
      *seeds = std::move(check);
      return true;
    }
  }
  // Consistent with the estimate: a solve would barely move it and its check would keep these edges.
  for (int64_t id : loops)
    if (const auto it = waiting_.find(id); it != waiting_.end()) it->second.checked = true;
  ++solves_skipped_;
  return false;
}

bool MapBackend::updateTracks(bool* chains_joined) {
  *chains_joined = false;
  if (!config_.ba.enabled) return false;
  const std::vector<int64_t>& disabled = graph_.disabledEdges();
  for (int64_t id : disabled) {
    const auto it = in_tracks_.find(id);
    if (it == in_tracks_.end()) continue;
    EdgeMatches matches = it->second.unpack();
    landmarks_.removeMatches(matches);
    waiting_[id] = {std::move(matches), true};
    in_tracks_.erase(it);
    ++counters_.edges_taken_back;
  }
  bool large = false;
  for (auto it = waiting_.begin(); it != waiting_.end();) {
    const PoseGraphEdge* e = graph_.edge(it->first);
    const bool off = std::binary_search(disabled.begin(), disabled.end(), it->first);
    if (!e || !it->second.checked || off || topology_.mapOf(e->from) != topology_.mapOf(e->to) ||
        !landmarks_.contains(e->from) || !landmarks_.contains(e->to)) {
      it = e ? std::next(it) : waiting_.erase(it);
      continue;
    }
    landmarks_.addMatches(it->second.matches);
    schedule_.mapChanged(topology_.mapOf(e->from));
    large = large || topology_.isLargeCycle(*e, config_.ba.global_after_loop_span);
    *chains_joined = *chains_joined || topology_.chainOf(e->from) != topology_.chainOf(e->to);
    in_tracks_[it->first] = PackedMatches::pack(std::move(it->second.matches));
    it = waiting_.erase(it);
    ++counters_.edges_in_tracks;
  }
  return large;
}

void MapBackend::adjustNewKeyframes(const std::vector<int64_t>& ids) {
  for (int64_t id : ids) {
    if (!landmarks_.contains(id)) continue;
    landmarks_.extendByProjection(id, topology_.odometryNeighbours(graph_, id));
    schedule_.keyframeAdded(topology_.mapOf(id));
  }
  const size_t first = ids.size() > static_cast<size_t>(config_.ba.max_local_per_batch)
                           ? ids.size() - static_cast<size_t>(config_.ba.max_local_per_batch)
                           : 0;
  for (size_t i = first; i < ids.size(); ++i) {
    if (!landmarks_.contains(ids[i]) || cancel_) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const double cpu0 = threadCpuMs();
    const int64_t anchor = topology_.anchorOf(topology_.mapOf(ids[i])).value_or(0);
    const BundleResult r = landmarks_.localAdjust(ids[i], anchor, &cancel_, check_);
    local_ms_.add(msSince(t0));
    local_cpu_ms_.add(threadCpuMs() - cpu0);
    ++counters_.local_runs;
    counters_.out_of_time += r.report.out_of_time ? 1 : 0;
    if (!BundleOutcome::count(r, "local", &counters_)) {
      ++counters_.local_failures;
      continue;
    }
    causes_.insert("local BA");
    applyBundle(r);
  }
}

void MapBackend::adjustGlobally(const std::set<int>& maps) {
  std::vector<int64_t> weak;
  for (int map : std::set<int>(maps)) {
    const std::optional<int64_t> anchor = topology_.anchorOf(map);
    if (!anchor || cancel_) continue;
    if (const size_t keyframes = topology_.keyframesIn(map); schedule_.overLimit(keyframes)) {
      schedule_.started(map);  // done with as if it ran: not owed again, nothing for a quiet map to do
      if (counters_.global_skipped++ == 0)
        log::info("optimiser: map ", map, " has ", keyframes,
                  " keyframes, more than ba.global_max_keyframes (", config_.ba.global_max_keyframes,
                  "): no global BA from now on, local BAs and the pose graph only");
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const double cpu0 = threadCpuMs();
    const BundleResult r = landmarks_.globalAdjust(map, *anchor, &cancel_, check_, outcome_.stepPriors(map));
    const double ms = msSince(t0), cpu_ms = threadCpuMs() - cpu0;
    schedule_.started(map);
    counters_.out_of_time += r.report.out_of_time ? 1 : 0;
    if (!BundleOutcome::count(r, "global", &counters_)) continue;
    causes_.insert(r.report.out_of_time ? "global BA (out of time)" : "global BA");
    const GlobalBundleSchedule::Verdict verdict =
        schedule_.finished(map, {r.report.out_of_time || r.report.at_iteration_cap,
                                 r.report.initial_rms_px, r.report.final_rms_px});
    counters_.global_fruitless += verdict.fruitless ? 1 : 0;
    const int backoff = verdict.backoff;
    log::info("optimiser: global BA of map ", map, ": ", r.report.frames, " keyframes, ", r.report.points,
              " landmarks, ", r.report.observations, " observations (", r.outliers_removed,
              " rejected), rms ", r.report.initial_rms_px, " -> ", r.report.final_rms_px, " px, ",
              r.report.iterations, " iterations", r.report.out_of_time ? " (out of time)" : "",
              r.report.linear_steps > 0 ? ", " + std::to_string(r.report.linear_steps) + " CG steps" : "",
              ", ", r.parts_kept, " parts kept in place (up to ", r.part_shift_m, " m, ", r.part_shift_deg,
              " deg), ", ms, " ms (", cpu_ms, " ms CPU)",
              backoff > 1 ? "; no gain: the next waits for growth x" : "",
              backoff > 1 ? std::to_string(backoff) : "");
    ++counters_.global_runs;
    counters_.global_ms_last = ms;
    counters_.global_ms_max = std::max(counters_.global_ms_max, ms);
    counters_.global_cpu_ms_last = cpu_ms;
    counters_.global_cpu_ms_max = std::max(counters_.global_cpu_ms_max, cpu_ms);
    counters_.global_keyframes_last = r.report.frames;
    applyBundle(r);
    weak.insert(weak.end(), r.weak.begin(), r.weak.end());
  }
  // Keyframes too weakly observed to be adjusted (restored ones that only a few new tracks reach; in a
  // large map, those the observation cap left with too few) are placed by their edges: a pose-graph solve
  // over the refined edges follows, of their neighbourhood when it fits (a fleet's map of thousands of
  // keyframes has hundreds of weak ones after every global BA).
  std::vector<int64_t> seeds;
  for (int64_t id : weak)
    for (int64_t e : topology_.edgesOf(id)) seeds.push_back(e);
  OptimizedPoses ignored;
  if (!seeds.empty() && !cancel_) solveGraph(&ignored, seeds);
}

void MapBackend::applyBundle(const BundleResult& r) {
  // The check of this outcome found its covisible edges already, unless it saw another one last.
  essential_.apply(r, outcome_.checkedEdges(r.moved));
  outcome_.forget();
}

std::shared_ptr<MapOptimization> MapBackend::result(bool solved, const OptimizedPoses& solve) {
  auto out = std::make_shared<MapOptimization>();
  out->graph_solved = solved;
  out->graph = solve;
  out->graph.ok = true;
  out->graph.T_map_kf = graph_.poses();
  logMoves(out->graph.T_map_kf);
  out->graph.disabled_edges = graph_.disabledEdges();
  out->graph.components = graph_.components();
  counters_.landmarks = landmarks_.stats();
  counters_.local_ms_median = local_ms_.median();
  counters_.local_ms_p90 = local_ms_.quantile(0.9);
  counters_.local_cpu_ms_median = local_cpu_ms_.median();
  counters_.local_cpu_ms_p90 = local_cpu_ms_.quantile(0.9);
  out->ba = counters_;
  out->solves_skipped = solves_skipped_;
  out->merges_aligned = merges_aligned_;
  out->local_solves = local_solves_;
  out->local_refused = local_refused_;
  return out;
}

void MapBackend::logMoves(const std::map<int64_t, SE3>& poses) {
  // Diagnostic (info): which work moved many keyframes beyond the octree's default rebuild thresholds
  // (3 cm, 0.02 rad). Both maps are ordered by node id. Nothing (no copy of every pose) when info is off.
  if (log::level() > log::Level::kInfo) {
    causes_.clear();
    published_.clear();
    return;
  }
  size_t moved = 0;
  double worst = 0.0;
  auto last = published_.begin();
  for (const auto& [id, T] : poses) {
    while (last != published_.end() && last->first < id) ++last;
    if (last == published_.end() || last->first != id) continue;
    const SE3 delta = last->second.inverse() * T;
    const double t = delta.translation().norm();
    if (t > 0.03 || se3::rotationAngle(delta) > 0.02) ++moved;
    worst = std::max(worst, t);
  }
  if (moved > 0 && moved * 10 >= poses.size()) {
    std::string causes;
    for (const std::string& c : causes_) causes += (causes.empty() ? "" : ", ") + c;
    log::info("optimiser: a result moved ", moved, " of ", poses.size(),
              " keyframes beyond 3 cm or 0.02 rad (up to ", worst, " m) after: ", causes);
  }
  causes_.clear();
  published_ = poses;
}

}  // namespace rgbdmap
