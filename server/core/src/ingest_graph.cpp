// The ingest pipeline's graph side: a stored keyframe into the index, the pose graph and the loop detector;
// loop edges; an optimisation result applied and turned into PoseCorrections and map worker pose updates.
#include <utility>

#include "ingest_pipeline.hpp"
#include "pose_corrections.hpp"
#include "rgbdmap/backend/edge_information.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

std::vector<LoopEdge> IngestPipeline::integrateLocked(const StoredKeyframe& stored,
                                                      const FrameFeatures& features, bool detect,
                                                      LoopStats* loop_stats) {
  const msg::Keyframe& kf = stored.keyframe;
  const int robot = registry_.index(kf.robot_id);
  std::optional<int64_t> prev;
  if (kf.previous_keyframe_id >= 0)
    prev = index_.find({robot, stored.session, kf.segment_id, kf.previous_keyframe_id});
  const bool split = kf.previous_keyframe_id >= 0 && !prev;
  const IndexedNode node = makeNodeLocked(stored, robot, prev, split);
  index_.add(node);
  addToGraphLocked(node, kf, prev);
  if (split) noteSplitLocked(node, kf);
  joinSplitSuccessorLocked(node);
  // One copy of the features, shared by the loop detector and the bundle adjustment's landmark map.
  auto shared = std::make_shared<const FrameFeatures>(features);
  features_->add(stored.node_id, shared);  // the cache decides how long they stay in RAM
  addToBatchLocked(node, shared);
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

/// The node of a stored keyframe: chained to its predecessor's optimised pose, or a map of its own.
IndexedNode IngestPipeline::makeNodeLocked(const StoredKeyframe& stored, int robot,
                                           std::optional<int64_t> prev, bool split) {
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

void IngestPipeline::addToGraphLocked(const IndexedNode& node, const msg::Keyframe& kf,
                                      std::optional<int64_t> prev) {
  const int64_t id = node.kf.node_id;
  if (const Status s = graph_.addNode(id, node.chain, node.kf.T_map_kf); !s) {
    log::error("server: graph node ", id, ": ", s.error());
    return;
  }
  const bool first = graph_.nodes().size() == 1;  // the first keyframe of the first robot holds the gauge
  if (first) graph_.setFixed(id);
  batch_.nodes.push_back({id, node.chain, node.kf.T_map_kf, first});
  if (prev)
    addOdometryEdgeLocked(id, *prev, kf.T_prev_cur,
                          odometryInformation(kf.information, config_.edgeInformation()));
}

void IngestPipeline::addToBatchLocked(const IndexedNode& node,
                                      const std::shared_ptr<const FrameFeatures>& features) {
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
  batch_.keyframes.push_back(std::move(k));
}

void IngestPipeline::addOdometryEdgeLocked(int64_t from, int64_t to, const SE3& T_prev_cur,
                                           const Mat6& information) {
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

Status IngestPipeline::addLoopEdgeLocked(const LoopEdge& edge) {
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

void IngestPipeline::onOptimized(const MapOptimization& result) {
  Lock lock(mutex_);
  if (!result.graph.ok) {
    log::warn("server: optimisation ", result.revision, " failed: ", result.graph.error);
    return;
  }
  applyOptimizedLocked(result);
  // Corrections for each robot's current process: its keyframes and T_map_odom of its newest segment.
  const auto corrections =
      buildCorrections(index_.nodes(), currentSessionsLocked(), counters_.graph_revision);
  noteCorrectionsLocked(corrections, std::chrono::steady_clock::now());
  std::vector<std::string> robots;  // the loop edges of each corrected robot's map (for visualisers)
  for (const auto& [robot, c] : corrections) robots.push_back(robot);
  const auto loops = buildLoopEdges(index_.nodes(), graph_.edges(), graph_.disabledEdges(), robots,
                                    counters_.graph_revision, config_.loop_edges_max);
  std::vector<MapNodePose> map_poses = mapPosesLocked();
  const uint64_t epoch = ++map_pose_epoch_;
  lock.unlock();
  if (map_worker_) map_worker_->updatePoses(std::move(map_poses), epoch);
  for (const auto& [robot, c] : corrections) {
    log::debug("server: corrections to ", robot, ": ", c.keyframes.size(), " keyframes");
    publisher_.publish(robot, c);
  }
  if (config_.loop_edges_max > 0)
    for (const auto& [robot, l] : loops) publisher_.publish(robot, l);
}

void IngestPipeline::applyOptimizedLocked(const MapOptimization& optimization) {
  const OptimizedPoses& result = optimization.graph;
  graph_.applyOptimized(result.T_map_kf, result.disabled_edges);
  for (const PoseGraphNode& n : graph_.nodes()) index_.node(n.id).kf.T_map_kf = n.T_map_kf;
  index_.setComponents(graph_.components());
  for (const IndexedNode& n : index_.nodes())
    if (n.valid) detector_.updatePose(static_cast<int>(n.kf.node_id), n.kf.map_id, n.kf.T_map_kf);
  ++counters_.optimizations;
  if (optimization.graph_solved) {
    ++counters_.graph_solves;
    counters_.last_optimize_ms = result.report.time_ms;
  }
  counters_.ba = optimization.ba;
  counters_.graph_solves_skipped = optimization.solves_skipped;
  counters_.graph_merges_aligned = optimization.merges_aligned;
  counters_.graph_solves_local = optimization.local_solves;
  counters_.graph_solves_local_refused = optimization.local_refused;
  counters_.loops_disabled = static_cast<int>(graph_.disabledEdges().size());
  counters_.graph_revision = revision_base_ + static_cast<int64_t>(optimization.revision);
}

std::map<std::string, int64_t> IngestPipeline::currentSessionsLocked() const {
  std::map<std::string, int64_t> sessions;
  for (const IndexedNode& n : index_.nodes())
    if (n.valid && !sessions.count(n.kf.robot_id))
      sessions[n.kf.robot_id] = registry_.currentSession(n.kf.robot_id);
  return sessions;
}

std::vector<MapNodePose> IngestPipeline::mapPosesLocked() const {
  std::vector<MapNodePose> map_poses;
  if (!map_worker_) return map_poses;
  map_poses.reserve(index_.nodes().size());
  for (const IndexedNode& n : index_.nodes())
    if (n.valid) map_poses.push_back({n.kf.node_id, n.kf.map_id, n.kf.T_map_kf});
  return map_poses;
}

}  // namespace rgbdmap
