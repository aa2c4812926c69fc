// MapOptimizer: batches from the ingest worker -> pose graph (additions, robust solve) -> landmark tracks
// (matches of kept edges) -> local and global bundle adjustment -> refined edges -> one result per batch.
#include "map_optimizer.hpp"

#include <algorithm>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "ingest_timings.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/graph/pose_graph_residual.hpp"

namespace rgbdmap {

void OptimizerBatch::append(OptimizerBatch&& other) {
  std::move(other.nodes.begin(), other.nodes.end(), std::back_inserter(nodes));
  std::move(other.edges.begin(), other.edges.end(), std::back_inserter(edges));
  std::move(other.keyframes.begin(), other.keyframes.end(), std::back_inserter(keyframes));
  for (auto& [id, m] : other.matches) matches.insert_or_assign(id, std::move(m));
  solve = solve || other.solve;
  must_solve = must_solve || other.must_solve;
  merge = merge || other.merge;
  global = global || other.global;
}

MapOptimizer::MapOptimizer(MapOptimizerConfig config, Callback callback)
    : config_(std::move(config)),
      callback_(std::move(callback)),
      landmarks_(config_.ba.landmarks),
      schedule_({config_.ba.global_every_keyframes, config_.ba.global_min_growth_fraction,
                 config_.ba.global_max_keyframes}),
      worker_({"rgbdmap-optim", 0, config_.ba.global_when_idle_s > 0 ? 0.5 : 0.0, [this] { onIdle(); },
               config_.nice}) {
  if (config_.features) landmarks_.setFeatureCache(config_.features);
  worker_.start();
}

MapOptimizer::~MapOptimizer() { stop(); }

uint64_t MapOptimizer::submit(OptimizerBatch batch) {
  uint64_t revision = 0;
  bool post = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return 0;
    revision = next_revision_++;
    pending_.append(std::move(batch));
    pending_revision_ = revision;
    last_batch_ = std::chrono::steady_clock::now();
    post = !std::exchange(task_queued_, true);
  }
  if (post) worker_.post([this] { processPending(); });
  return revision;
}

bool MapOptimizer::globalDue() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return global_due_;
}

void MapOptimizer::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    pending_ = {};
  }
  cancel_ = true;
  worker_.stop();
}

void MapOptimizer::processPending() {
  OptimizerBatch b;
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    b = std::exchange(pending_, {});
    revision = pending_revision_;
    task_queued_ = false;
  }
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
                                           [this](int map) { return keyframesIn(map); }));
  }
  if (cancel_) return;
  publish(revision, solved, solve);
}

void MapOptimizer::onIdle() {
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const double quiet_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - last_batch_).count();
    if (stopping_ || task_queued_ || quiet_s < config_.ba.global_when_idle_s || !global_due_) return;
    // A result of its own: robots take corrections only from a newer revision than they have.
    revision = pending_revision_ = next_revision_++;
  }
  // A quiet map gets what the busy one put off: the whole-graph solve after neighbourhood solves, the BA.
  OptimizedPoses solve;
  const bool solved = graph_stale_ && solveGraph(&solve);
  if (config_.ba.enabled) adjustGlobally(schedule_.changed());
  if (!cancel_) publish(revision, solved, solve);
}

void MapOptimizer::applyAdditions(const OptimizerBatch& b) {
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
    chain_of_[n.id] = n.robot;
  }
  for (const PoseGraphEdge& e : b.edges) {
    if (const Status s = graph_.addEdge(e); !s) {
      log::warn("optimiser: ", s.error());
      continue;
    }
    edges_of_node_[e.from].push_back(e.id);
    edges_of_node_[e.to].push_back(e.id);
  }
  for (const auto& [id, m] : b.matches) waiting_[id] = {m, false};
  refreshMaps();
  for (const LandmarkKeyframe& k : b.keyframes) {
    const auto pose = graph_.pose(k.id);
    if (!pose || !config_.ba.enabled) continue;
    LandmarkKeyframe kf = k;
    kf.T_map_kf = *pose;
    kf.map_id = map_of_[k.id];
    if (const Status s = landmarks_.addKeyframe(std::move(kf)); !s) log::warn("optimiser: ", s.error());
  }
}

void MapOptimizer::refreshMaps() {
  std::set<int64_t> fixed;
  for (const PoseGraphNode& n : graph_.nodes())
    if (n.fixed) fixed.insert(n.id);
  anchor_of_.clear();
  for (const std::vector<int64_t>& component : graph_.components()) {
    const int map = static_cast<int>(component.front());
    int64_t anchor = component.front();
    for (int64_t id : component)
      if (fixed.count(id)) anchor = id;
    anchor_of_[map] = anchor;
    for (int64_t id : component) {
      auto [it, inserted] = map_of_.try_emplace(id, map);
      if (!inserted && it->second != map) {  // merged (or split off): landmarks follow their keyframes
        it->second = map;
        schedule_.keyframeAdded(map);  // new to this map's global BA
        landmarks_.setPose(id, map, *graph_.pose(id));
      }
    }
  }
}

bool MapOptimizer::solveGraph(OptimizedPoses* out, const std::vector<int64_t>& seeds) {
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
      for (int64_t id : local.moved_nodes) landmarks_.setPose(id, map_of_[id], *graph_.pose(id));
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
  for (const PoseGraphNode& n : graph_.nodes()) landmarks_.setPose(n.id, map_of_[n.id], n.T_map_kf);
  return true;
}

bool MapOptimizer::needsSolve(const OptimizerBatch& b, std::vector<int64_t>* seeds) {
  const double limit = config_.graph.solve_above_chi2;
  if (b.must_solve || limit <= 0.0) return true;
  std::vector<int64_t> check;  // edges a solve would have to reconcile
  if (b.merge) {
    const PoseGraph::Alignment moved = graph_.alignSubmaps(config_.graph);
    for (int64_t id : moved.moved_nodes) landmarks_.setPose(id, map_of_[id], *graph_.pose(id));
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

bool MapOptimizer::isLargeCycle(const PoseGraphEdge& e) const {
  if (e.kind == EdgeKind::kOdometry) return false;
  if (chain_of_.at(e.from) != chain_of_.at(e.to)) return true;
  return std::abs(e.from - e.to) > config_.ba.global_after_loop_span;
}

bool MapOptimizer::updateTracks(bool* chains_joined) {
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
    if (!e || !it->second.checked || off || map_of_[e->from] != map_of_[e->to] ||
        !landmarks_.contains(e->from) || !landmarks_.contains(e->to)) {
      it = e ? std::next(it) : waiting_.erase(it);
      continue;
    }
    landmarks_.addMatches(it->second.matches);
    schedule_.mapChanged(map_of_[e->from]);
    large = large || isLargeCycle(*e);
    *chains_joined = *chains_joined || chain_of_.at(e->from) != chain_of_.at(e->to);
    in_tracks_[it->first] = PackedMatches::pack(std::move(it->second.matches));
    it = waiting_.erase(it);
    ++counters_.edges_in_tracks;
  }
  return large;
}

void MapOptimizer::adjustNewKeyframes(const std::vector<int64_t>& ids) {
  for (int64_t id : ids) {
    if (!landmarks_.contains(id)) continue;
    landmarks_.extendByProjection(id, odometryNeighbours(id));
    const int map = map_of_[id];
    schedule_.keyframeAdded(map);
  }
  const size_t first = ids.size() > static_cast<size_t>(config_.ba.max_local_per_batch)
                           ? ids.size() - static_cast<size_t>(config_.ba.max_local_per_batch)
                           : 0;
  for (size_t i = first; i < ids.size(); ++i) {
    if (!landmarks_.contains(ids[i]) || cancel_) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const double cpu0 = threadCpuMs();
    const BundleResult r = landmarks_.localAdjust(ids[i], anchor_of_[map_of_[ids[i]]], &cancel_, check_);
    local_ms_.add(msSince(t0));
    local_cpu_ms_.add(threadCpuMs() - cpu0);
    ++counters_.local_runs;
    counters_.out_of_time += r.report.out_of_time ? 1 : 0;
    if (!countBundle(r, "local")) {
      ++counters_.local_failures;
      continue;
    }
    causes_.insert("local BA");
    applyBundle(r);
  }
}

std::vector<int64_t> MapOptimizer::odometryNeighbours(int64_t id) const {
  std::vector<int64_t> out;
  const auto it = edges_of_node_.find(id);
  if (it == edges_of_node_.end()) return out;
  for (int64_t e_id : it->second)
    if (const PoseGraphEdge* e = graph_.edge(e_id); e && e->kind == EdgeKind::kOdometry)
      out.push_back(e->from == id ? e->to : e->from);
  return out;
}

size_t MapOptimizer::keyframesIn(int map) const {
  size_t keyframes = 0;
  for (const auto& [id, m] : map_of_) keyframes += m == map;
  return keyframes;
}

void MapOptimizer::adjustGlobally(const std::set<int>& maps) {
  std::vector<int64_t> weak;
  for (int map : std::set<int>(maps)) {
    const auto anchor = anchor_of_.find(map);
    if (anchor == anchor_of_.end() || cancel_) continue;
    if (const size_t keyframes = keyframesIn(map); schedule_.overLimit(keyframes)) {
      schedule_.started(map);  // done with as if it ran: not owed again, nothing for a quiet map to do
      if (counters_.global_skipped++ == 0)
        log::info("optimiser: map ", map, " has ", keyframes,
                  " keyframes, more than ba.global_max_keyframes (", config_.ba.global_max_keyframes,
                  "): no global BA from now on, local BAs and the pose graph only");
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const double cpu0 = threadCpuMs();
    const BundleResult r = landmarks_.globalAdjust(map, anchor->second, &cancel_, check_, stepPriors(map));
    const double ms = msSince(t0), cpu_ms = threadCpuMs() - cpu0;
    schedule_.started(map);
    counters_.out_of_time += r.report.out_of_time ? 1 : 0;
    if (!countBundle(r, "global")) continue;
    causes_.insert(r.report.out_of_time ? "global BA (out of time)" : "global BA");
    const GlobalBundleSchedule::Verdict verdict =
        schedule_.finished(map, {r.report.out_of_time, r.report.initial_rms_px, r.report.final_rms_px});
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
    for (int64_t e : edges_of_node_[id]) seeds.push_back(e);
  OptimizedPoses ignored;
  if (!seeds.empty() && !cancel_) solveGraph(&ignored, seeds);
}

std::vector<MapOptimizer::CovisibleEdge> MapOptimizer::covisibleEdgeChanges(
    const std::vector<std::pair<int64_t, SE3>>& poses) const {
  std::unordered_map<int64_t, const SE3*> moved;
  for (const auto& [id, T] : poses) moved[id] = &T;
  const auto poseOf = [&](int64_t id) -> std::optional<SE3> {
    const auto it = moved.find(id);
    if (it != moved.end()) return *it->second;
    return graph_.pose(id);
  };
  const std::vector<int64_t>& disabled = graph_.disabledEdges();
  std::vector<CovisibleEdge> out;
  std::unordered_set<int64_t> seen;
  for (const auto& [id, T] : poses) {
    std::unordered_set<int64_t> shared;
    for (const auto& [other, n] : landmarks_.covisible(id)) shared.insert(other);
    const auto edges = edges_of_node_.find(id);
    if (edges == edges_of_node_.end()) continue;
    for (int64_t e_id : edges->second) {
      const PoseGraphEdge* e = graph_.edge(e_id);
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

std::string MapOptimizer::checkBundle(const std::vector<std::pair<int64_t, SE3>>& proposed) {
  checked_.moved.clear();
  for (const auto& [id, T] : proposed) checked_.moved.push_back(id);
  checked_.edges = covisibleEdgeChanges(proposed);  // applyBundle takes them if the outcome is applied
  const double max_t = config_.ba.max_edge_change_m, max_deg = config_.ba.max_edge_change_deg;
  for (const CovisibleEdge& c : checked_.edges)
    if ((max_t > 0.0 && c.t > max_t) || (max_deg > 0.0 && c.deg > max_deg))
      return "it would change edge " + std::to_string(c.edge->id) + " (" + std::to_string(c.edge->from) +
             "-" + std::to_string(c.edge->to) + ", keyframes sharing landmarks) by " + std::to_string(c.t) +
             " m and " + std::to_string(c.deg) + " deg";
  return "";
}

bool MapOptimizer::countBundle(const BundleResult& r, const char* kind) {
  if (r.refused) {
    ++counters_.refused;
    log::warn("optimiser: ", kind, " bundle adjustment of ", r.report.frames, " keyframes",
              r.report.out_of_time ? " (out of time)" : "", " refused: ", r.error);
  }
  counters_.parts_kept += r.parts_kept;
  counters_.part_shift_m_max = std::max(counters_.part_shift_m_max, r.part_shift_m);
  return r.ok;
}

std::vector<BundlePrior> MapOptimizer::stepPriors(int map) const {
  std::vector<BundlePrior> out;
  if (!config_.ba.global_step_priors) return out;
  const std::vector<int64_t>& disabled = graph_.disabledEdges();
  const auto inMap = [&](int64_t id) {
    const auto it = map_of_.find(id);
    return it != map_of_.end() && it->second == map && landmarks_.contains(id);
  };
  for (const PoseGraphEdge& e : graph_.edges()) {
    if (!inMap(e.from) || !inMap(e.to) || std::binary_search(disabled.begin(), disabled.end(), e.id))
      continue;
    if (landmarks_.sharedLandmarks(e.from, e.to) >= config_.ba.landmarks.min_covisibility) continue;
    Mat6 sqrt_information;
    if (!sqrtInformation(residualInformation(e.T_from_to, e.information), &sqrt_information)) continue;
    out.push_back({e.from, e.to, e.T_from_to, sqrt_information});
  }
  return out;
}

void MapOptimizer::applyBundle(const BundleResult& r) {
  std::set<int64_t> in(r.moved.begin(), r.moved.end());
  in.insert(r.fixed.begin(), r.fixed.end());
  std::vector<std::pair<int64_t, SE3>> moved;
  for (int64_t id : r.moved) {
    graph_.setPose(id, *landmarks_.pose(id));
    moved.emplace_back(id, *landmarks_.pose(id));
  }
  // The edges at a moved keyframe whose other end the adjustment saw too, and shares landmarks with, take
  // its relative pose. Without shared landmarks the adjustment knows nothing of that relative pose (an
  // odometry step into a room not seen before): a global BA moved such steps by up to 2.2 m, and the
  // measurement, overwritten, no longer held the map together (a room torn without a false loop).
  // The check of this outcome (checkBundle) found them already.
  const std::vector<CovisibleEdge> edges =
      checked_.moved == r.moved ? std::move(checked_.edges) : covisibleEdgeChanges(moved);
  checked_ = {};
  // Diagnostic: measurements moved by more than 5 cm or 2 deg.
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
    graph_.setEdgeMeasurement(c.edge->id, c.measured);
  }
  if (far > 0)
    log::warn("optimiser: a bundle adjustment of ", r.report.frames, " keyframes",
              r.report.out_of_time ? " (out of time)" : "", " moved ", far, " edge measurements (",
              far_odometry, " odometry) by more than 5 cm or 2 deg, up to ", far_t, " m and ", far_deg,
              " deg");
}

void MapOptimizer::logMoves(const std::map<int64_t, SE3>& poses) {
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

void MapOptimizer::publish(uint64_t revision, bool solved, const OptimizedPoses& solve) {
  auto out = std::make_shared<MapOptimization>();
  out->revision = revision;
  out->graph_solved = solved;
  out->graph = solve;
  out->graph.revision = revision;
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
  {
    std::lock_guard<std::mutex> lock(mutex_);
    global_due_ = (config_.ba.enabled && !schedule_.changed().empty()) || graph_stale_;
  }
  if (callback_) callback_(out);
}

}  // namespace rgbdmap
