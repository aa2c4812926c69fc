// The ingest pipeline: Hello, the keyframe path (admission, decoding, durable store, acknowledgement, loop
// edges) and the readers. Graph insertion and optimisation results are in ingest_graph.cpp.
#include "ingest_pipeline.hpp"

#include <algorithm>

#include <utility>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/intake/image_admission.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

namespace rgbdmap {

using Clock = std::chrono::steady_clock;

IngestPipeline::IngestPipeline(const MapServerConfig& config, RobotRegistry& registry,
                               RobotPublisher& publisher, int64_t revision_base)
    : config_(config),
      registry_(registry),
      publisher_(publisher),
      revision_base_(revision_base),
      detector_(CameraIntrinsics{}, config.loop),
      hello_hold_(static_cast<size_t>(config.reorder_capacity), config.robot_queue_bytes),
      extractor_(config.features),
      decode_extractor_(config.features) {
  features_ = std::make_shared<FeatureCache>(config.features_in_memory,
                                             [this](int64_t id) { return loadFeatures(id); });
  detector_.setFeatureCache(features_);
}

Result<FrameFeatures> IngestPipeline::loadFeatures(int64_t node_id) const {
  using R = Result<FrameFeatures>;
  if (!store_) return R::failure("no store");
  Result<StoredKeyframe> read = store_->readKeyframe(node_id);
  if (!read) return R::failure(read.error());
  std::optional<CameraIntrinsics> camera;
  {
    std::lock_guard<std::mutex> lock(loader_mutex_);
    if (const auto it = loader_cameras_.find(read->keyframe.robot_id); it != loader_cameras_.end())
      camera = it->second;
  }
  if (!camera) return R::failure("no camera for robot " + read->keyframe.robot_id);
  Result<FrameFeatures> f = featuresFromMessage(read->keyframe, PinholeCamera(*camera));
  if (!f) log::error("server: features of keyframe ", node_id, " cannot be read back: ", f.error());
  return f;
}

void IngestPipeline::setLoaderCamera(const std::string& robot_id, const CameraIntrinsics& camera) {
  std::lock_guard<std::mutex> lock(loader_mutex_);
  loader_cameras_.insert_or_assign(robot_id, camera);
}

void IngestPipeline::attach(MapStore* store, SubmitGraph submit) {
  std::lock_guard<std::mutex> lock(mutex_);
  store_ = store;
  submit_ = std::move(submit);
  counters_.recovery = store_->recovery();
}

void IngestPipeline::onHello(const msg::Hello& hello) {
  std::vector<msg::Keyframe> held;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto registered =
        registry_.hello(hello.robot_id, hello.header.session, hello.camera, hello.T_base_camera);
    if (!registered) {
      log::warn("server: hello from ", hello.robot_id, ": ", registered.error());
      return;
    }
    if (*registered) {
      if (const Status s = registry_.save(store_->directory()); !s) {
        registry_unsaved_ = true;  // saved again before the next keyframe is stored
        log::error("server: ", s.error());
      }
      detector_.setRobotCamera(registry_.index(hello.robot_id), hello.camera);
      setLoaderCamera(hello.robot_id, hello.camera);
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

IngestPipeline::Prepared IngestPipeline::prepare(msg::Keyframe kf) {
  Prepared prepared{std::move(kf), {}, {}, 0.0, 0.0};
  const msg::Keyframe& k = prepared.keyframe;
  const int robot = registry_.index(k.robot_id);  // the registry is thread-safe
  prepared.camera = registry_.camera(k.robot_id);
  if (robot < 0 || !prepared.camera || seen({robot, k.header.session, k.segment_id, k.keyframe_id}))
    return prepared;
  const ImageLimits limits{config_.max_image_pixels, config_.max_image_bytes};
  if (!imagesRefusedBeforeDecode(k.images, *prepared.camera, limits).empty()) return prepared;
  const auto t0 = Clock::now();
  const double cpu0 = threadCpuMs();
  prepared.decoded = decode(decode_extractor_, k, *prepared.camera);
  decoded_ahead_.fetch_add(1, std::memory_order_relaxed);
  prepared.decode_ms = msSince(t0);
  prepared.decode_cpu_ms = threadCpuMs() - cpu0;
  return prepared;
}

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
  const KeyframeKey key{robot, kf.header.session, kf.segment_id, kf.keyframe_id};
  if (!admitLocked(kf, key, lock)) return;
  const ImageLimits limits{config_.max_image_pixels, config_.max_image_bytes};
  if (std::string why = imagesRefusedBeforeDecode(kf.images, *camera, limits); !why.empty()) {
    registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kRefusedBeforeDecode);
    return refuseLocked(kf, key, why, lock);
  }
  if (!storeWritableLocked()) return;  // not acknowledged: the robot sends it again
  KeyframeTiming timing;
  const auto t_decode = Clock::now();
  ++counters_.keyframes_decoded;
  const bool extract = needsServerFeatures(kf);
  // Decoded on the decode thread for this camera, or here (no camera then, or a Hello changed it since).
  const bool ahead = prepared.decoded && prepared.camera && sameIntrinsics(*prepared.camera, *camera);
  Result<Decoded> decoded = ahead ? std::move(*prepared.decoded) : decodeLocked(kf, *camera);
  if (!decoded) return refuseLocked(kf, key, decoded.error(), lock);
  WaitingKeyframe waiting;
  StoredKeyframe& stored = waiting.stored;
  stored.node_id = next_node_id_;
  stored.session = kf.header.session;
  stored.keyframe = kf;
  if (extract) {
    // Stored with the extracted features: a restart reads them back as if the robot had sent them.
    if (const Status s = putFeatures(decoded->features, &stored.keyframe); !s)
      return refuseLocked(kf, key, "extracted features: " + s.error(), lock);
    ++counters_.keyframes_features_extracted;
  }
  timing.decode_ms = ahead ? prepared.decode_ms : msSince(t_decode);
  if (ahead) timing.decode_thread_cpu_ms = prepared.decode_cpu_ms;
  const auto t_store = Clock::now();
  if (const Status s = store_->appendKeyframe(stored); !s) {
    log::error("server: cannot store keyframe ", kf.keyframe_id, " of ", kf.robot_id, ": ", s.error());
    return;  // not acknowledged: the robot sends it again
  }
  ++next_node_id_;
  noteSeen(key);
  stored.keyframe.images = {};
  timing.store_ms = msSince(t_store);
  // Stored first, acknowledged at once whatever its order; the graph takes it in chain order.
  publisher_.acknowledge(kf.robot_id, kf.keyframe_id, true, "");
  waiting.features = std::move(decoded->features);
  Deferred d{std::move(waiting), key, std::nullopt, timing};
  if (deferred_.size() < kDeferredWithImages) d.images = std::move(decoded->images);
  d.timing.total_ms = msSince(t0);
  d.timing.cpu_ms = threadCpuMs() - cpu0;
  deferred_.push_back(std::move(d));
  deferred_count_.store(deferred_.size(), std::memory_order_relaxed);
  counters_.keyframes_deferred_max =
      std::max(counters_.keyframes_deferred_max, static_cast<int>(deferred_.size()));
  ++newly_deferred_;
}

bool IngestPipeline::placeDeferred() {
  const auto t0 = Clock::now();
  const double cpu0 = threadCpuMs();
  Lock lock(mutex_);
  if (deferred_.empty()) return false;
  Deferred d = std::move(deferred_.front());
  deferred_.pop_front();
  deferred_count_.store(deferred_.size(), std::memory_order_relaxed);
  // The reorder timeout counts from here: a predecessor stored a moment later is placed a moment later.
  d.waiting.since = t0;
  placeLocked(std::move(d.waiting), d.images ? &*d.images : nullptr, true);
  giveUpWaitingLocked(Clock::now(), config_.reorder_timeout_s, true);  // the per-robot bound
  KeyframeTiming timing = d.timing;
  timing.loops_ms = msSince(t0);
  timing.total_ms += timing.loops_ms;
  timing.cpu_ms += threadCpuMs() - cpu0;
  timings_.add(timing);
  return true;
}

size_t IngestPipeline::deferred() const { return deferred_count_.load(std::memory_order_relaxed); }

size_t IngestPipeline::takeNewlyDeferred() {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::exchange(newly_deferred_, 0);
}

/// False for a keyframe seen before (stored, waiting in the reorder buffer or refused): answered again.
bool IngestPipeline::admitLocked(const msg::Keyframe& kf, const KeyframeKey& key, Lock& lock) {
  const bool deferred =
      std::any_of(deferred_.begin(), deferred_.end(), [&](const Deferred& d) { return d.key == key; });
  if (!index_.contains(key) && !reorder_.contains(key) && !index_.refused(key) && !deferred) return true;
  const bool accepted = !index_.refused(key);
  registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kDuplicate);
  lock.unlock();
  publisher_.acknowledge(kf.robot_id, kf.keyframe_id, accepted, accepted ? "duplicate" : "refused before");
  return false;
}

void IngestPipeline::refuseLocked(const msg::Keyframe& kf, const KeyframeKey& key, const std::string& reason,
                                  Lock& lock) {
  index_.refuse(key);
  noteSeen(key);
  ++counters_.keyframes_refused;
  registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kRefused);
  // Keyframes that waited for this one will not get it: they start a new chain.
  for (WaitingKeyframe& w : reorder_.takeSuccessors(key))
    integrateWithSuccessorsLocked(std::move(w), nullptr, true);
  lock.unlock();
  log::warn("server: keyframe ", kf.keyframe_id, " of ", kf.robot_id, " refused: ", reason);
  publisher_.acknowledge(kf.robot_id, kf.keyframe_id, false, reason);
}

bool IngestPipeline::storeWritableLocked() {
  if (registry_unsaved_ && !store_->health().failed && registry_.save(store_->directory()))
    registry_unsaved_ = false;
  if (!registry_unsaved_ && !store_->health().failed) {
    if (std::exchange(store_down_logged_, false)) log::info("server: storing keyframes again");
    return true;
  }
  ++counters_.keyframes_unacked_store_failed;
  if (!std::exchange(store_down_logged_, true))
    log::warn(
        "server: ",
        registry_unsaved_ ? "robots.txt cannot be saved" : "the map store failed: " + store_->health().error,
        "; keyframes are left unacknowledged until it works again");
  return false;
}

Result<IngestPipeline::Decoded> IngestPipeline::decodeLocked(const msg::Keyframe& kf,
                                                             const CameraIntrinsics& camera) {
  return decode(extractor_, kf, camera);
}

Result<IngestPipeline::Decoded> IngestPipeline::decode(OrbExtractor& extractor, const msg::Keyframe& kf,
                                                       const CameraIntrinsics& camera) {
  auto images = msg::decodeKeyframeImages(kf);
  if (!images) return Result<Decoded>::failure("images: " + images.error());
  if (needsServerFeatures(kf)) {
    // Used as they are stored (float keypoints and depths): a restart, or the feature cache reading them
    // back, gets exactly these.
    msg::Keyframe as_stored;
    as_stored.keyframe_id = kf.keyframe_id;
    if (const Status s = putFeatures(extractServerFeatures(extractor, *images, camera), &as_stored); !s)
      return Result<Decoded>::failure("extracted features: " + s.error());
    auto features = featuresFromMessage(as_stored, PinholeCamera(camera));
    if (!features) return Result<Decoded>::failure(features.error());
    return Decoded{std::move(*images), std::move(*features)};
  }
  auto features = featuresFromMessage(kf, PinholeCamera(camera));
  if (!features) return Result<Decoded>::failure(features.error());
  return Decoded{std::move(*images), std::move(*features)};
}

void IngestPipeline::noteSeen(const KeyframeKey& key) {
  std::lock_guard<std::mutex> lock(seen_mutex_);
  seen_.insert(key);
}

bool IngestPipeline::seen(const KeyframeKey& key) const {
  std::lock_guard<std::mutex> lock(seen_mutex_);
  return seen_.count(key) != 0;
}

void IngestPipeline::addLiveLocked(const StoredKeyframe& stored, const FrameFeatures& features,
                                   const DecodedImages* images) {
  LoopStats loop_stats;
  const std::vector<LoopEdge> edges = integrateLocked(stored, features, true, &loop_stats);
  const IndexedNode& n = index_.node(stored.node_id);
  const std::optional<CameraIntrinsics> camera = registry_.camera(n.kf.robot_id);
  if (map_worker_ && camera)
    map_worker_->addKeyframe({n.kf.node_id, n.kf.robot_id, n.kf.map_id, n.kf.T_map_kf, *camera,
                              images ? images->depth : cv::Mat(), images ? images->color : cv::Mat(), true,
                              n.kf.keyframe_id, map_pose_epoch_});
  counters_.loop_candidates += loop_stats.candidates;
  counters_.loop_brute_force_no_prior += loop_stats.brute_force_no_prior;
  counters_.loop_brute_force_fallback += loop_stats.brute_force_fallback;
  counters_.loop_brute_force_fallback_verified += loop_stats.brute_force_fallback_verified;
  counters_.loop_fallbacks_skipped += loop_stats.fallbacks_skipped;
  counters_.loop_features_unavailable += loop_stats.features_unavailable;
  timings_.addVerify(loop_stats.verify_ms);
  for (int r = 0; r < kLoopRejectionCount; ++r)
    counters_.loops_rejected_by_reason[r] += loop_stats.rejected_by_reason[r];
  const int added = addDetectedLoopsLocked(edges, n.robot);
  counters_.loops_accepted += added;
  ++counters_.keyframes;
  registry_.recordKeyframe(n.kf.robot_id, RobotRegistry::KeyframeOutcome::kPlaced);
  // With bundle adjustment every keyframe goes to the optimiser (a local BA refines it and its neighbours);
  // a pose-graph solve when loops came or chains joined. Without, the additions wait for the next solve.
  const bool joined = std::exchange(graph_joined_, false);
  const bool solve = added > 0 || joined;
  if (solve || config_.ba.enabled) submitOptimizationLocked(solve, joined);
}

/// Adds the detector's loop edges to the graph and stores them. Returns how many were added.
int IngestPipeline::addDetectedLoopsLocked(const std::vector<LoopEdge>& edges, int robot) {
  int added = 0;
  std::vector<StoredLoop> to_store;
  for (const LoopEdge& edge : edges) {
    if (const Status s = addLoopEdgeLocked(edge); !s) {
      log::warn("server: loop edge ", edge.from_id, "-", edge.to_id, ": ", s.error());
      continue;
    }
    to_store.push_back({edge.from_id, edge.to_id, edge.T_from_to, edge.information, edge.inliers,
                        edge.motion_measure, edge.inlier_pairs});
    ++added;
    // Between two maps (as the last applied result has them): they merge; the optimiser moves the one met
    // for the first time onto the other and solves if the edges still disagree.
    if (index_.node(edge.from_id).kf.map_id != index_.node(edge.to_id).kf.map_id) batch_.merge = true;
    registry_.countLoop(index_.node(edge.from_id).kf.robot_id);
    if (index_.node(edge.to_id).robot != robot) registry_.countLoop(index_.node(edge.to_id).kf.robot_id);
  }
  // One write and one sync for all of this keyframe's loops (a lost loop edge costs accuracy, not data).
  // Loops that could not be stored (a failed store) go with the next ones.
  to_store.insert(to_store.begin(), loops_unsaved_.begin(), loops_unsaved_.end());
  loops_unsaved_.clear();
  if (const Status s = store_->appendLoops(to_store); !s) {
    const bool later = store_->health().failed;
    log::error("server: cannot store ", to_store.size(), " loop(s)", later ? ", kept for later: " : ": ",
               s.error());
    if (later) loops_unsaved_ = std::move(to_store);
  }
  return added;
}

void IngestPipeline::submitOptimizationLocked(bool solve, bool must_solve) {
  batch_.solve = batch_.solve || solve || must_solve;
  batch_.must_solve = batch_.must_solve || must_solve;
  if (submit_) submit_(std::exchange(batch_, {}));
}

void IngestPipeline::submitRestoredLoops() {
  std::lock_guard<std::mutex> lock(mutex_);
  // The restored graph goes to the optimiser in one batch; a solve when it has loops or joined chains.
  const bool solve = counters_.restored_loops > 0 || std::exchange(graph_joined_, false);
  if (solve || !batch_.empty()) submitOptimizationLocked(solve, solve);
}

MapServerStats IngestPipeline::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  MapServerStats s = counters_;
  s.keyframes_decoded_ahead = decoded_ahead_.load(std::memory_order_relaxed);
  timings_.fill(&s);
  s.maps = static_cast<int>(index_.mapCount());
  s.keyframes_waiting = static_cast<int>(reorder_.size());
  s.keyframes_deferred = static_cast<int>(deferred_.size());
  s.hello_hold = hello_hold_.stats();
  const FeatureCacheStats fc = features_->stats();
  s.features_resident = fc.resident;
  s.features_loads = fc.loads;
  s.features_load_failures = fc.load_failures;
  s.retrieval_index_bytes = detector_.retrievalIndexBytes();
  s.robots = registry_.stats();
  for (ServerRobotStats& r : s.robots) {
    const int robot = registry_.index(r.robot_id);
    index_.fillRobotStats(&r, robot);
    r.keyframes_waiting = static_cast<int>(reorder_.waiting(robot));
  }
  return s;
}

std::vector<ServerKeyframe> IngestPipeline::keyframes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return index_.validKeyframes();
}

std::vector<ServerLoop> IngestPipeline::loops() const {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::vector<int64_t>& disabled = graph_.disabledEdges();  // sorted
  std::vector<ServerLoop> out;
  for (const PoseGraphEdge& e : graph_.edges())
    if (e.kind != EdgeKind::kOdometry)
      out.push_back({e.from, e.to, e.T_from_to, e.kind == EdgeKind::kInterRobot,
                     !std::binary_search(disabled.begin(), disabled.end(), e.id)});
  return out;
}

std::vector<double> IngestPipeline::ingestTimesMs() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return timings_.ingestMs();
}

int64_t IngestPipeline::graphRevision() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_.graph_revision;
}

}  // namespace rgbdmap
