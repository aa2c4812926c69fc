// A stored keyframe into the index, the pose graph and the loop detector; odometry and loop edges, split
// chains joined by a late predecessor; an optimisation result applied.
#include "rgbdmap/ingest/map_graph.hpp"

#include <algorithm>
#include <utility>

#include "rgbdmap/backend/edge_information.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

MapGraph::MapGraph(const MapServerConfig& config, RobotRegistry& registry,
                   std::shared_ptr<FeatureCache> features, IngestStats& stats, int64_t revision_base)
    : config_(config),
      registry_(registry),
      features_(std::move(features)),
      stats_(stats),
      revision_base_(revision_base),
      detector_(CameraIntrinsics{}, config.loop) {
  detector_.setFeatureCache(features_);
}

std::vector<LoopEdge> MapGraph::integrate(const StoredKeyframe& stored, const FrameFeatures& features,
                                          bool detect, LoopStats* loop_stats) {
  const msg::Keyframe& kf = stored.keyframe;
  const int robot = registry_.index(kf.robot_id);
  std::optional<int64_t> prev;
  if (kf.previous_keyframe_id >= 0)
    prev = index_.find({robot, stored.session, kf.segment_id, kf.previous_keyframe_id});
  const bool split = kf.previous_keyframe_id >= 0 && !prev;
  const IndexedNode node = makeNode(stored, robot, prev, split);
  index_.add(node);
  addToGraph(node, kf, prev);
  if (split) noteSplit(node, kf);
  joinSplitSuccessor(node);
  // One copy of the features, shared by the loop detector and the bundle adjustment's landmark map.
  auto shared = std::make_shared<const FrameFeatures>(features);
  features_->add(stored.node_id, shared);  // the cache decides how long they stay in RAM
  addToBatch(node, shared, kf, prev);
  LoopKeyframe lk(static_cast<int>(stored.node_id), robot, node.kf.map_id, node.kf.T_map_kf,
                  std::move(shared));
  if (!detect) {
    if (const Status s = detector_.restoreKeyframe(std::move(lk)); !s)
      log::error("server: restore: ", s.error());
    return {};
  }
  const LoopDetectorConfig& lc = config_.loop;
  const LoopDetector::MeasuredPoses measured =
      lc.prior_max_hops > 0 ? graph_.measuredPosesNear(stored.node_id, lc.prior_max_hops,
                                                       static_cast<size_t>(lc.prior_max_nodes))
                            : LoopDetector::MeasuredPoses{};
  auto detection = detector_.addKeyframe(std::move(lk), &measured);
  if (!detection) {
    log::error("server: loop detection for keyframe ", stored.node_id, ": ", detection.error());
    return {};
  }
  if (loop_stats) *loop_stats = detection->stats;
  return detection->edges;
}

std::vector<PlacementVote> MapGraph::placeVotes(const std::shared_ptr<const FrameFeatures>& features,
                                                int robot, int query_id,
                                                const std::optional<PlacementEstimate>& predicted,
                                                const SE3& provisional, LoopStats* loop_stats) const {
  const LoopKeyframe query(query_id, robot, predicted ? predicted->map_id : -1,
                           predicted ? predicted->T_map_kf : provisional, features);
  const Result<LoopDetection> detection = detector_.place(query);
  if (!detection) {
    log::error("server: placement query: ", detection.error());
    return {};
  }
  if (loop_stats) *loop_stats = detection->stats;
  std::vector<PlacementVote> votes;
  for (const LoopEdge& e : detection->edges) {
    if (e.to_id < 0 || static_cast<size_t>(e.to_id) >= index_.nodes().size()) continue;
    const IndexedNode& n = index_.node(e.to_id);
    if (!n.valid) continue;
    // T_from_to = T_query_other: the query's pose is the other's times its inverse.
    votes.push_back(
        {e.to_id, n.kf.map_id, se3::normalized(n.kf.T_map_kf * e.T_from_to.inverse()), e.inliers});
  }
  return votes;
}

/// The node of a stored keyframe: chained to its predecessor's optimised pose, or a map of its own.
IndexedNode MapGraph::makeNode(const StoredKeyframe& stored, int robot, std::optional<int64_t> prev,
                               bool split) {
  const msg::Keyframe& kf = stored.keyframe;
  IndexedNode node;
  node.valid = true;
  node.robot = robot;
  if (prev)
    node.chain = index_.node(*prev).chain;
  else if (split)
    node.chain = index_.newChain(robot, stored.session, kf.segment_id);
  else
    node.chain = index_.chainFor(robot, stored.session, kf.segment_id);
  node.kf.node_id = stored.node_id;
  node.kf.robot_id = kf.robot_id;
  node.kf.session = stored.session;
  node.kf.segment = kf.segment_id;
  node.kf.keyframe_id = kf.keyframe_id;
  node.kf.timestamp = kf.timestamp;
  node.kf.T_odom_kf = kf.T_odom_cam;
  if (prev) {
    const IndexedNode& p = index_.node(*prev);
    node.kf.T_map_kf = se3::normalized(p.kf.T_map_kf * kf.T_prev_cur);
    node.kf.map_id = p.kf.map_id;
  } else {
    // A new chain starts a map of its own until a loop joins it, z-up: T_map_odom = the robot's camera mount
    // (map = the base frame of its first keyframe). A split one starts where the odometry of its segment
    // puts it (its latest keyframe in the graph), so the robot's T_map_odom does not jump.
    node.kf.T_map_kf = se3::normalized(registry_.mount(kf.robot_id) * kf.T_odom_cam);
    const auto latest =
        split ? index_.latestBefore({robot, stored.session, kf.segment_id, kf.keyframe_id}) : std::nullopt;
    if (latest) {
      const IndexedNode& l = index_.node(*latest);
      node.kf.T_map_kf = se3::normalized(l.kf.T_map_kf * l.kf.T_odom_kf.inverse() * kf.T_odom_cam);
    }
    node.kf.map_id = static_cast<int>(stored.node_id);
  }
  return node;
}

void MapGraph::addToGraph(const IndexedNode& node, const msg::Keyframe& kf, std::optional<int64_t> prev) {
  const int64_t id = node.kf.node_id;
  if (const Status s = graph_.addNode(id, node.chain, node.kf.T_map_kf); !s) {
    log::error("server: graph node ", id, ": ", s.error());
    return;
  }
  const bool first = graph_.nodes().size() == 1;  // the first keyframe of the first robot holds the gauge
  if (first) graph_.setFixed(id);
  batch_.nodes.push_back({id, node.chain, node.kf.T_map_kf, first});
  if (prev)
    addOdometryEdge(id, *prev, kf.T_prev_cur, odometryInformation(kf.information, config_.edgeInformation()));
}

void MapGraph::addToBatch(const IndexedNode& node, const std::shared_ptr<const FrameFeatures>& features,
                          const msg::Keyframe& kf, std::optional<int64_t> prev) {
  const std::optional<CameraIntrinsics> camera = registry_.camera(node.kf.robot_id);
  if (!camera || !config_.ba.enabled) return;
  LandmarkKeyframe k;
  k.id = node.kf.node_id;
  k.map_id = node.kf.map_id;
  k.camera = {camera->fx, camera->fy, camera->cx, camera->cy};
  k.width = camera->width;
  k.height = camera->height;
  k.T_map_kf = node.kf.T_map_kf;
  k.features = features;
  if (prev) {
    const Vec3 step = predictedRollingShutter(kf.T_prev_cur, kf.timestamp - index_.node(*prev).kf.timestamp,
                                              camera->readout_s);
    k.w_prior = noteShutterStep(k.id, step, true);
    // The predecessor's centre moves to the mean of its two steps (a chain's first: this step alone).
    batch_.w_priors.emplace_back(*prev, noteShutterStep(*prev, step, false));
  } else if (const auto it = shutter_steps_.find(k.id); it != shutter_steps_.end() && it->second.after) {
    k.w_prior = *it->second.after;  // a late predecessor joining its split successor (joinSplitSuccessor)
  }
  batch_.keyframes.push_back(std::move(k));
}

Vec3 MapGraph::noteShutterStep(int64_t id, const Vec3& w, bool before) {
  ShutterSteps& s = shutter_steps_[id];
  (before ? s.before : s.after) = w;
  if (!s.before || !s.after) return before ? *s.before : *s.after;
  const Vec3 mean = 0.5 * (*s.before + *s.after);
  shutter_steps_.erase(id);
  return mean;
}

void MapGraph::addOdometryEdge(int64_t from, int64_t to, const SE3& T_prev_cur, const Mat6& information) {
  PoseGraphEdge e;
  e.id = next_edge_id_++;
  e.from = from;
  e.to = to;
  e.T_from_to = T_prev_cur.inverse();
  e.information = information;
  e.kind = EdgeKind::kOdometry;
  if (const Status s = graph_.addEdge(e); !s) {
    log::error("server: odometry edge: ", s.error());
    return;
  }
  batch_.edges.push_back(e);
}

Status MapGraph::addLoopEdge(const LoopEdge& edge) {
  PoseGraphEdge e;
  e.id = next_edge_id_++;
  e.from = edge.from_id;
  e.to = edge.to_id;
  e.T_from_to = edge.T_from_to;
  e.information = loopInformation(edge.information, config_.edgeInformation());
  e.kind = index_.node(edge.from_id).chain != index_.node(edge.to_id).chain ? EdgeKind::kInterRobot
                                                                            : EdgeKind::kLoop;
  if (const Status s = graph_.addEdge(e); !s) return s;
  batch_.edges.push_back(e);
  if (!edge.inlier_pairs.empty()) batch_.matches[e.id] = {e.from, e.to, edge.inlier_pairs};
  return Status::success();
}

void MapGraph::applyOptimized(const MapOptimization& optimization) {
  const OptimizedPoses& result = optimization.graph;
  graph_.applyOptimized(result.T_map_kf, result.disabled_edges);
  for (const PoseGraphNode& n : graph_.nodes()) index_.node(n.id).kf.T_map_kf = n.T_map_kf;
  index_.setComponents(graph_.components());
  for (const IndexedNode& n : index_.nodes())
    if (n.valid) detector_.updatePose(static_cast<int>(n.kf.node_id), n.kf.map_id, n.kf.T_map_kf);
  ++stats_.optimizations;
  if (optimization.graph_solved) {
    ++stats_.graph_solves;
    stats_.last_optimize_ms = result.report.time_ms;
  }
  ba_ = optimization.ba;
  stats_.graph_solves_skipped = optimization.solves_skipped;
  stats_.graph_merges_aligned = optimization.merges_aligned;
  stats_.graph_solves_local = optimization.local_solves;
  stats_.graph_solves_local_refused = optimization.local_refused;
  stats_.loops_disabled = static_cast<int>(graph_.disabledEdges().size());
  stats_.graph_revision = revision_base_ + static_cast<int64_t>(optimization.revision);
}

std::map<std::string, int64_t> MapGraph::currentSessions() const {
  std::map<std::string, int64_t> sessions;
  for (const IndexedNode& n : index_.nodes())
    if (n.valid && !sessions.count(n.kf.robot_id))
      sessions[n.kf.robot_id] = registry_.currentSession(n.kf.robot_id);
  return sessions;
}

std::vector<MapNodePose> MapGraph::mapPoses() const {
  std::vector<MapNodePose> map_poses;
  map_poses.reserve(index_.nodes().size());
  for (const IndexedNode& n : index_.nodes())
    if (n.valid) map_poses.push_back({n.kf.node_id, n.kf.map_id, n.kf.T_map_kf});
  return map_poses;
}

void MapGraph::noteSplit(const IndexedNode& node, const msg::Keyframe& kf) {
  const KeyframeKey missing{node.robot, node.kf.session, node.kf.segment, kf.previous_keyframe_id};
  const bool refused = index_.refused(missing);
  registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kChainSplit);
  log::info("server: keyframe ", kf.keyframe_id, " of ", kf.robot_id, " starts a new chain: its predecessor ",
            kf.previous_keyframe_id, refused ? " was refused" : " did not come");
  if (!refused)
    split_heads_[missing] = {node.kf.node_id, kf.T_prev_cur,
                             odometryInformation(kf.information, config_.edgeInformation())};
}

void MapGraph::joinSplitSuccessor(const IndexedNode& node) {
  const auto it = split_heads_.find({node.robot, node.kf.session, node.kf.segment, node.kf.keyframe_id});
  if (it == split_heads_.end()) return;
  const SplitHead head = it->second;
  split_heads_.erase(it);
  addOdometryEdge(head.node_id, node.kf.node_id, head.T_prev_cur, head.information);
  graph_joined_ = true;
  // The head's own step predicts its rolling shutter (and the step after its late predecessor's), as if the
  // predecessor had come in time.
  const std::optional<CameraIntrinsics> camera = registry_.camera(node.kf.robot_id);
  if (camera && config_.ba.enabled) {
    const double dt = index_.node(head.node_id).kf.timestamp - node.kf.timestamp;
    const Vec3 step = predictedRollingShutter(head.T_prev_cur, dt, camera->readout_s);
    batch_.w_priors.emplace_back(head.node_id, noteShutterStep(head.node_id, step, true));
    noteShutterStep(node.kf.node_id, step, false);  // node's own prior: addToBatch, next
  }
  log::info("server: keyframe ", node.kf.keyframe_id, " of ", node.kf.robot_id,
            " came late: its odometry edge joins the chain split off at node ", head.node_id);
}

/// Adds the detector's loop edges to the graph. Returns those added, as they are stored.
std::vector<StoredLoop> MapGraph::addDetectedLoops(const std::vector<LoopEdge>& edges, int robot) {
  std::vector<StoredLoop> added;
  for (const LoopEdge& edge : edges) {
    if (const Status s = addLoopEdge(edge); !s) {
      log::warn("server: loop edge ", edge.from_id, "-", edge.to_id, ": ", s.error());
      continue;
    }
    added.push_back({edge.from_id, edge.to_id, edge.T_from_to, edge.information, edge.inliers,
                     edge.motion_measure, edge.inlier_pairs});
    // Between two maps (as the last applied result has them): they merge; the optimiser moves the one met
    // for the first time onto the other and solves if the edges still disagree.
    if (index_.node(edge.from_id).kf.map_id != index_.node(edge.to_id).kf.map_id) batch_.merge = true;
    registry_.countLoop(index_.node(edge.from_id).kf.robot_id);
    if (index_.node(edge.to_id).robot != robot) registry_.countLoop(index_.node(edge.to_id).kf.robot_id);
  }
  return added;
}

Status MapGraph::restoreLoopEdge(const LoopEdge& edge) {
  if (const Status s = addLoopEdge(edge); !s) return s;
  detector_.restoreEdge(edge);
  return Status::success();
}

void MapGraph::submit(bool solve, bool must_solve) {
  batch_.solve = batch_.solve || solve || must_solve;
  batch_.must_solve = batch_.must_solve || must_solve;
  if (submit_) submit_(std::exchange(batch_, {}));
}

std::vector<ServerLoop> MapGraph::loops() const {
  const std::vector<int64_t>& disabled = graph_.disabledEdges();  // sorted
  std::vector<ServerLoop> out;
  for (const PoseGraphEdge& e : graph_.edges())
    if (e.kind != EdgeKind::kOdometry)
      out.push_back({e.from, e.to, e.T_from_to, e.kind == EdgeKind::kInterRobot,
                     !std::binary_search(disabled.begin(), disabled.end(), e.id)});
  return out;
}

void MapGraph::fillStats(IngestStats* s) const {
  s->maps = static_cast<int>(index_.mapCount());
  const FeatureCacheStats fc = features_->stats();
  s->features_resident = fc.resident;
  s->features_loads = fc.loads;
  s->features_load_failures = fc.load_failures;
  s->retrieval_index_bytes = detector_.retrievalIndexBytes();
}

}  // namespace rgbdmap
