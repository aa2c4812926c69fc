// The ingest pipeline: Hello, the keyframe path (admission, decoding, store and acknowledgement, deferred
// placement), optimisation results and corrections, and the readers.
#include "rgbdmap/ingest/ingest_pipeline.hpp"

#include <algorithm>
#include <utility>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/ingest/map_restore.hpp"
#include "rgbdmap/ingest/pose_corrections.hpp"
#include "rgbdmap/intake/image_admission.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

namespace rgbdmap {

using Clock = std::chrono::steady_clock;

IngestPipeline::IngestPipeline(const MapServerConfig& config, RobotRegistry& registry,
                               RobotPublisher& publisher, int64_t revision_base)
    : config_(config),
      registry_(registry),
      publisher_(publisher),
      features_(std::make_shared<FeatureCache>(config.features_in_memory,
                                               [this](int64_t id) { return loader_.load(id); })),
      decoder_(config, registry),
      graph_(config, registry, features_, stats_, revision_base),
      order_(registry, graph_.index(), config.reorder_capacity,
             [this](const WaitingKeyframe& w, const DecodedImages* images, bool live) {
               integrateLocked(w, images, live);
             }),
      intake_(registry, stats_),
      corrections_(registry, stats_),
      hello_hold_(static_cast<size_t>(config.reorder_capacity), config.robot_queue_bytes),
      localize_(config.placement) {}

void IngestPipeline::attach(MapStore* store, SubmitGraph submit) {
  std::lock_guard<std::mutex> lock(mutex_);
  store_ = store;
  loader_.attach(store);
  intake_.attach(store);
  graph_.setSubmit(std::move(submit));
  stats_.recovery = store_->recovery();
}

Status IngestPipeline::restore() {
  std::lock_guard<std::mutex> lock(mutex_);
  return MapRestore(*store_, {registry_, graph_, order_, intake_, decoder_, loader_, stats_}).run();
}

void IngestPipeline::submitRestoredLoops() {
  std::lock_guard<std::mutex> lock(mutex_);
  // The restored graph goes to the optimiser in one batch; a solve when it has loops or joined chains.
  const bool solve = stats_.restored_loops > 0 || graph_.takeJoined();
  if (solve || !graph_.batchEmpty()) graph_.submit(solve, solve);
}

void IngestPipeline::onHello(const msg::Hello& hello) {
  std::vector<msg::Keyframe> held;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool localize =
        config_.frozen_map || std::count(hello.capabilities.begin(), hello.capabilities.end(),
                                         std::string(msg::kCapabilityLocalize)) > 0;
    const auto registered =
        registry_.hello(hello.robot_id, hello.header.session, hello.camera, hello.T_base_camera, localize);
    if (!registered) {
      log::warn("server: hello from ", hello.robot_id, ": ", registered.error());
      return;
    }
    if (localize) {
      graph_.setRobotCamera(MapGraph::kLocalizeRobotBase + registry_.index(hello.robot_id), hello.camera);
      log::info("server: robot ", hello.robot_id, " (", hello.software_version,
                ") localises in the map, session ", hello.header.session);
    } else if (*registered) {
      intake_.saveRegistry();
      graph_.setRobotCamera(registry_.index(hello.robot_id), hello.camera);
      loader_.setCamera(hello.robot_id, hello.camera);
      log::info("server: robot ", hello.robot_id, " (", hello.software_version, ") joined, session ",
                hello.header.session);
    }
    held = hello_hold_.release(hello.robot_id);
  }
  if (!held.empty())
    log::info("server: ", held.size(), " keyframe(s) of ", hello.robot_id,
              " came before its hello: taken in now");
  for (const msg::Keyframe& kf : held) onKeyframe(kf);
}

void IngestPipeline::onKeyframe(const msg::Keyframe& kf) { onKeyframe(Prepared{kf, {}, {}, 0.0, 0.0}); }

void IngestPipeline::onKeyframe(Prepared prepared) {
  const msg::Keyframe& kf = prepared.keyframe;
  const auto t0 = Clock::now();
  const double cpu0 = threadCpuMs();
  Lock lock(mutex_);
  const int robot = registry_.index(kf.robot_id);
  const std::optional<CameraIntrinsics> camera = registry_.camera(kf.robot_id);
  if (robot < 0 || !camera) {
    // No Hello yet (lost or overtaken): held until it comes (not acknowledged before).
    registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kWaitingForHello);
    hello_hold_.hold(kf);
    return;
  }
  registry_.noteSession(kf.robot_id, kf.header.session);  // a restarted server heard no Hello
  if (registry_.localizing(kf.robot_id)) return localizeLocked(std::move(prepared), *camera, robot, lock);
  const KeyframeKey key{robot, kf.header.session, kf.segment_id, kf.keyframe_id};
  if (!admitLocked(kf, key, lock)) return;
  const ImageLimits limits{config_.max_image_pixels, config_.max_image_bytes};
  if (std::string why = imagesRefusedBeforeDecode(kf.images, *camera, limits); !why.empty()) {
    registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kRefusedBeforeDecode);
    return refuseLocked(kf, key, why, lock);
  }
  if (!intake_.storeWritable()) return;  // not acknowledged: the robot sends it again
  KeyframeTiming timing;
  const auto t_decode = Clock::now();
  ++stats_.keyframes_decoded;
  // Decoded on the decode thread for this camera, or here (no camera then, or a Hello changed it since).
  const bool ahead = prepared.decoded && prepared.camera && sameIntrinsics(*prepared.camera, *camera);
  Result<Decoded> decoded = ahead ? std::move(*prepared.decoded) : decoder_.decodeOnWorker(kf, *camera);
  if (!decoded) return refuseLocked(kf, key, decoded.error(), lock);
  WaitingKeyframe waiting;
  StoredKeyframe& stored = waiting.stored;
  stored.node_id = intake_.nextNodeId();
  stored.session = kf.header.session;
  stored.keyframe = kf;
  if (needsServerFeatures(kf)) {
    // Stored with the extracted features: a restart reads them back as if the robot had sent them.
    if (const Status s = putFeatures(decoded->features, &stored.keyframe); !s)
      return refuseLocked(kf, key, "extracted features: " + s.error(), lock);
    ++stats_.keyframes_features_extracted;
  }
  timing.decode_ms = ahead ? prepared.decode_ms : msSince(t_decode);
  if (ahead) timing.decode_thread_cpu_ms = prepared.decode_cpu_ms;
  storeLocked(kf, key, std::move(waiting), std::move(*decoded), timing, {t0, cpu0});
}

void IngestPipeline::storeLocked(const msg::Keyframe& kf, const KeyframeKey& key, WaitingKeyframe waiting,
                                 DecodedKeyframe decoded, KeyframeTiming timing, Started started) {
  StoredKeyframe& stored = waiting.stored;
  const auto t_store = Clock::now();
  if (!intake_.store(stored)) return;  // not acknowledged: the robot sends it again
  decoder_.noteSeen(key);
  stored.keyframe.images = {};
  timing.store_ms = msSince(t_store);
  // Stored first, acknowledged at once whatever its order; the graph takes it in chain order.
  answer(kf, true, "");
  waiting.features = std::move(decoded.features);
  DeferredKeyframe d{std::move(waiting), key, std::nullopt, timing};
  if (intake_.keepsImages()) d.images = std::move(decoded.images);
  d.timing.total_ms = msSince(started.t0);
  d.timing.cpu_ms = threadCpuMs() - started.cpu0;
  intake_.defer(std::move(d));
}

void IngestPipeline::startFeeding(MapWorker* map_worker) {
  std::lock_guard<std::mutex> lock(mutex_);
  map_worker_ = map_worker;
  for (const IndexedNode& n : graph_.index().nodes()) {
    const auto camera = n.valid ? registry_.camera(n.kf.robot_id) : std::nullopt;
    if (!camera) continue;
    map_worker_->addKeyframe({n.kf.node_id,
                              n.kf.robot_id,
                              n.kf.map_id,
                              n.kf.T_map_kf,
                              *camera,
                              {},
                              {},
                              false,
                              n.kf.keyframe_id,
                              map_pose_epoch_});
  }
}

void IngestPipeline::onOptimized(const MapOptimization& result) {
  Lock lock(mutex_);
  if (!result.graph.ok) {
    log::warn("server: optimisation ", result.revision, " failed: ", result.graph.error);
    return;
  }
  graph_.applyOptimized(result);
  // Corrections for each robot's current process: its keyframes and T_map_odom of its newest segment.
  const auto corrections =
      buildCorrections(graph_.index().nodes(), graph_.currentSessions(), stats_.graph_revision);
  corrections_.noteSent(corrections, Clock::now());
  std::vector<std::string> robots;  // the loop edges of each corrected robot's map (for visualisers)
  for (const auto& [robot, c] : corrections) robots.push_back(robot);
  const auto loops =
      buildLoopEdges(graph_.index().nodes(), graph_.poseGraph().edges(), graph_.poseGraph().disabledEdges(),
                     robots, stats_.graph_revision, config_.loop_edges_max);
  std::vector<MapNodePose> map_poses = map_worker_ ? graph_.mapPoses() : std::vector<MapNodePose>{};
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

void IngestPipeline::onTick() {
  Lock lock(mutex_);
  const auto now = Clock::now();
  order_.giveUpWaiting(now, config_.reorder_timeout_s, true);
  const CorrectionsFollower::FollowUp follow = corrections_.followHeartbeats(now, graph_.index());
  if (follow.optimise) graph_.submit();
  lock.unlock();
  for (const auto& [robot, c] : follow.again) {
    log::debug("server: corrections (revision ", c.graph_revision, ") to ", robot, " again");
    publisher_.publish(robot, c);
  }
}

void IngestPipeline::onStop() {
  Lock lock(mutex_);
  if (intake_.deferredNow() > 0) {
    log::info("server: stopping with ", intake_.deferredNow(), " stored keyframe(s) not placed yet: ",
              "into the graph by odometry, without loop detection, for the final outputs");
    for (DeferredKeyframe& d : intake_.takeAllDeferred()) order_.place(std::move(d.waiting), nullptr, false);
  }
  const size_t waiting = order_.waiting();
  if (waiting == 0) return;
  log::info("server: stopping with ", waiting, " stored keyframe(s) still waiting for a predecessor: ",
            "placed by odometry in new chains for the final outputs");
  order_.giveUpWaiting(Clock::time_point::max(), 0.0, false);
}

bool IngestPipeline::placeDeferred() {
  const auto t0 = Clock::now();
  const double cpu0 = threadCpuMs();
  Lock lock(mutex_);
  std::optional<DeferredKeyframe> d = intake_.takeDeferred();
  if (!d) return false;
  // The reorder timeout counts from here: a predecessor stored a moment later is placed a moment later.
  d->waiting.since = t0;
  order_.place(std::move(d->waiting), d->images ? &*d->images : nullptr, true);
  order_.giveUpWaiting(Clock::now(), config_.reorder_timeout_s, true);  // the per-robot bound
  KeyframeTiming timing = d->timing;
  timing.loops_ms = msSince(t0);
  timing.total_ms += timing.loops_ms;
  timing.cpu_ms += threadCpuMs() - cpu0;
  timings_.add(timing);
  return true;
}

size_t IngestPipeline::takeNewlyDeferred() {
  std::lock_guard<std::mutex> lock(mutex_);
  return intake_.takeNewlyDeferred();
}

bool IngestPipeline::admitLocked(const msg::Keyframe& kf, const KeyframeKey& key, Lock& lock) {
  const KeyframeIndex& index = graph_.index();
  if (!index.contains(key) && !order_.contains(key) && !index.refused(key) && !intake_.isDeferred(key))
    return true;
  const bool accepted = !index.refused(key);
  registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kDuplicate);
  lock.unlock();
  answer(kf, accepted, accepted ? "duplicate" : "refused before");
  return false;
}

void IngestPipeline::refuseLocked(const msg::Keyframe& kf, const KeyframeKey& key, const std::string& reason,
                                  Lock& lock) {
  graph_.index().refuse(key);
  decoder_.noteSeen(key);
  ++stats_.keyframes_refused;
  registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kRefused);
  // Keyframes that waited for this one will not get it: they start a new chain.
  order_.predecessorRefused(key);
  lock.unlock();
  log::warn("server: keyframe ", kf.keyframe_id, " of ", kf.robot_id, " refused: ", reason);
  answer(kf, false, reason);
}

void IngestPipeline::answer(const msg::Keyframe& kf, bool accepted, const std::string& reason) {
  if (answered_) answered_(kf.robot_id, kf.header.session, kf.keyframe_id, accepted, reason);
  publisher_.acknowledge(kf.robot_id, kf.keyframe_id, accepted, reason);
}

void IngestPipeline::integrateLocked(const WaitingKeyframe& w, const DecodedImages* images, bool live) {
  if (live) return addLiveLocked(w.stored, w.features, images);
  graph_.integrate(w.stored, w.features, false, nullptr);
  registry_.recordKeyframe(w.stored.keyframe.robot_id, RobotRegistry::KeyframeOutcome::kPlaced);
  ++stats_.keyframes;
}

/// Graph, loop detection, map worker (`images`, or read back from the store when null), loop edges,
/// optimisation.
void IngestPipeline::addLiveLocked(const StoredKeyframe& stored, const FrameFeatures& features,
                                   const DecodedImages* images) {
  LoopStats loop_stats;
  const std::vector<LoopEdge> edges = graph_.integrate(stored, features, true, &loop_stats);
  const IndexedNode& n = graph_.index().node(stored.node_id);
  const std::optional<CameraIntrinsics> camera = registry_.camera(n.kf.robot_id);
  if (map_worker_ && camera)
    map_worker_->addKeyframe({n.kf.node_id, n.kf.robot_id, n.kf.map_id, n.kf.T_map_kf, *camera,
                              images ? images->depth : cv::Mat(), images ? images->color : cv::Mat(), true,
                              n.kf.keyframe_id, map_pose_epoch_});
  countLoopStatsLocked(loop_stats);
  std::vector<StoredLoop> added = graph_.addDetectedLoops(edges, n.robot);
  const int added_count = static_cast<int>(added.size());
  intake_.storeLoops(std::move(added));
  stats_.loops_accepted += added_count;
  ++stats_.keyframes;
  registry_.recordKeyframe(n.kf.robot_id, RobotRegistry::KeyframeOutcome::kPlaced);
  // With bundle adjustment every keyframe goes to the optimiser (a local BA refines it and its neighbours);
  // a pose-graph solve when loops came or chains joined. Without, the additions wait for the next solve.
  const bool joined = graph_.takeJoined();
  const bool solve = added_count > 0 || joined;
  if (solve || config_.ba.enabled) graph_.submit(solve, joined);
}

void IngestPipeline::countLoopStatsLocked(const LoopStats& loop_stats) {
  stats_.loop_candidates += loop_stats.candidates;
  stats_.loop_brute_force_no_prior += loop_stats.brute_force_no_prior;
  stats_.loop_brute_force_fallback += loop_stats.brute_force_fallback;
  stats_.loop_brute_force_fallback_verified += loop_stats.brute_force_fallback_verified;
  stats_.loop_fallbacks_skipped += loop_stats.fallbacks_skipped;
  stats_.loop_features_unavailable += loop_stats.features_unavailable;
  timings_.addVerify(loop_stats.verify_ms);
  for (int r = 0; r < kLoopRejectionCount; ++r)
    stats_.loops_rejected_by_reason[r] += loop_stats.rejected_by_reason[r];
}

IngestReport IngestPipeline::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  IngestReport r;
  r.ingest = stats_;
  r.ba = graph_.bundleAdjustment();
  r.ingest.keyframes_decoded_ahead = decoder_.decodedAhead();
  timings_.fill(&r.ingest);
  graph_.fillStats(&r.ingest);
  r.ingest.keyframes_waiting = static_cast<int>(order_.waiting());
  r.ingest.keyframes_deferred = static_cast<int>(intake_.deferredNow());
  r.hello_hold = hello_hold_.stats();
  r.robots = registry_.stats();
  const int main_map = mainMapLocked();
  const std::map<std::string, LocalizeRobotStats> localizing = localize_.stats();
  for (ServerRobotStats& robot_stats : r.robots) {
    robot_stats.keyframes_waiting = static_cast<int>(order_.waiting(registry_.index(robot_stats.robot_id)));
    fillPlacementLocked(&robot_stats, main_map, localizing);
  }
  return r;
}

std::map<std::string, bool> IngestPipeline::placedRobots() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const int main_map = mainMapLocked();
  const std::map<std::string, LocalizeRobotStats> localizing = localize_.stats();
  std::map<std::string, bool> placed;
  for (ServerRobotStats robot : registry_.stats()) {
    fillPlacementLocked(&robot, main_map, localizing);
    placed[robot.robot_id] = robot.placed;
  }
  return placed;
}

int IngestPipeline::mainMapLocked() const {
  const auto& nodes = graph_.index().nodes();
  return nodes.empty() || !nodes.front().valid ? -1 : nodes.front().kf.map_id;
}

void IngestPipeline::fillPlacementLocked(ServerRobotStats* robot, int main_map,
                                         const std::map<std::string, LocalizeRobotStats>& localizing) const {
  graph_.index().fillRobotStats(robot, registry_.index(robot->robot_id));
  // A mapping robot is placed once its newest keyframe is in the map of the graph's first keyframe; a
  // localising one by its own session only (none yet: unplaced), never by the stored map's keyframes.
  robot->placed = robot->map_id >= 0 && robot->map_id == main_map;
  if (robot->mode != "localize") return;
  const auto it = localizing.find(robot->robot_id);
  const LocalizeRobotStats session = it == localizing.end() ? LocalizeRobotStats{} : it->second;
  robot->placed = session.placed;
  robot->map_id = session.map_id;
  robot->first_placement_s = session.first_placement_s;
  robot->keyframes_localized = session.keyframes;
  robot->keyframes_matched = session.keyframes_matched;
}

std::vector<ServerKeyframe> IngestPipeline::keyframes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return graph_.index().validKeyframes();
}

std::vector<ServerLoop> IngestPipeline::loops() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return graph_.loops();
}

std::vector<double> IngestPipeline::ingestTimesMs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return timings_.ingestMs();
}

int64_t IngestPipeline::graphRevision() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_.graph_revision;
}

}  // namespace rgbdmap
