#include "rgbdmap/workers/map_worker.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/model/map_server_config.hpp"
#include "rgbdmap/proto/codec.hpp"

#include "rgbdmap/workers/thread_time.hpp"

namespace rgbdmap {
namespace {

using Clock = std::chrono::steady_clock;

double nowS() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }

/// The stream is checked every map_stream_delay_s (or every map_stream_period_s without a delay); 0: off.
SerialWorkerOptions workerOptions(const MapWorkerConfig& config, std::function<void()> stream) {
  SerialWorkerOptions options;
  options.name = "rgbdmap-map";
  options.period_s = config.map_stream_period_s;  // 0: no map stream
  if (config.map_stream_delay_s > 0.0 && options.period_s > 0.0)
    options.period_s = std::min(options.period_s, config.map_stream_delay_s);
  options.on_period = std::move(stream);
  return options;
}

}  // namespace

MapWorkerConfig mapWorkerConfig(const MapServerConfig& server) {
  MapWorkerConfig m;
  m.occupancy = server.occupancy;
  m.occupancy.rebuild_nice = server.background_nice;
  m.occupancy.spill_dir = server.map_dir;
  m.slice = server.slice;
  m.slice_period_s = server.slice_period_s;
  m.map_stream_period_s = server.map_stream_period_s;
  m.map_stream_delay_s = server.map_stream_delay_s;
  return m;
}

MapWorker::MapWorker(const MapWorkerConfig& config, const MapStore& store, MapWorkerPublishers publishers)
    : config_(config),
      store_(store),
      publishers_(std::move(publishers)),
      occupancy_(config.occupancy),
      worker_(workerOptions(config, [this] { onStreamTick(); })) {
  if (!occupancy_.spillError().empty())
    log::warn("map: every kept keyframe cloud stays in RAM: ", occupancy_.spillError());
}

MapWorker::~MapWorker() { stop(); }

void MapWorker::start() { worker_.start(); }

void MapWorker::stop() { worker_.stop(); }

void MapWorker::flushStreams() {
  worker_.post([this] { publishStreams(); });
}

void MapWorker::addKeyframe(MapKeyframeJob job) {
  bool with_images = !job.depth.empty();
  if (with_images && queued_images_.load() >= kMaxQueuedImages) {
    job.depth.release();  // read back from the store when its turn comes
    job.color.release();
    with_images = false;
    ++images_deferred_;
  }
  if (with_images) ++queued_images_;
  worker_.post([this, with_images, job = std::move(job)]() mutable {
    insertKeyframe(job);
    if (with_images) --queued_images_;
  });
}

void MapWorker::updatePoses(std::vector<MapNodePose> poses, uint64_t epoch) {
  {
    std::lock_guard<std::mutex> lock(poses_mutex_);
    pending_poses_ = std::move(poses);  // the whole map's poses: the newest update replaces older ones
    pending_epoch_ = epoch;
    if (poses_queued_) {
      ++pose_updates_coalesced_;
      return;
    }
    poses_queued_ = true;
  }
  worker_.post([this] { applyPendingPoses(); });
}

std::optional<MapNodePose> MapWorker::insertedPose(int64_t node_id) const {
  std::lock_guard<std::mutex> lock(state_mutex_);
  const auto it = nodes_.find(node_id);
  if (it == nodes_.end()) return std::nullopt;
  return MapNodePose{node_id, it->second.map_id, it->second.T_map_kf};
}

bool MapWorker::waitIdle(double timeout_s) const {
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  if (!worker_.waitIdleUntil(deadline)) return false;
  return occupancy_.waitIdle(std::max(0.0, std::chrono::duration<double>(deadline - Clock::now()).count()));
}

const KeyframeCloudMaker& MapWorker::makerFor(const std::string& robot_id, const CameraIntrinsics& camera) {
  auto& slot = makers_[robot_id];
  if (!slot.second || !sameIntrinsics(slot.first, camera)) {
    slot.first = camera;
    slot.second = std::make_unique<KeyframeCloudMaker>(PinholeCamera(camera), config_.occupancy);
  }
  return *slot.second;
}

bool MapWorker::readBackImages(MapKeyframeJob& job) const {
  const auto stored = store_.readKeyframe(job.node_id);
  if (!stored) {
    log::error("map: keyframe ", job.node_id, " not re-inserted: ", stored.error());
    return false;
  }
  const auto images = msg::decodeKeyframeImages(stored->keyframe);
  if (!images) {
    log::error("map: keyframe ", job.node_id, " not re-inserted: images: ", images.error());
    return false;
  }
  job.depth = images->depth;
  job.color = images->color;
  return true;
}

void MapWorker::insertKeyframe(MapKeyframeJob& job) {
  const double cpu0 = threadCpuMs();
  if (const auto early = early_poses_.find(job.node_id); early != early_poses_.end()) {
    if (early_epoch_ > job.pose_epoch) {  // an update applied before its turn knows a newer pose
      job.map_id = early->second.map_id;
      job.T_map_kf = early->second.T_map_kf;
    }
    early_poses_.erase(early);
  }
  if (job.depth.empty() && !readBackImages(job)) return;  // restored: read the images back from the store
  auto cloud =
      makerFor(job.robot_id, job.camera).make(job.node_id, job.depth, job.camera.depth_scale, job.color);
  if (!cloud) {
    log::error("map: keyframe ", job.node_id, " of ", job.robot_id, ": ", cloud.error());
    return;
  }
  if (const Status s = occupancy_.insert(std::move(*cloud), job.map_id, job.T_map_kf); !s) {
    log::error("map: keyframe ", job.node_id, " of ", job.robot_id, ": ", s.error());
    return;
  }
  const double ms = threadCpuMs() - cpu0;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    nodes_[job.node_id] = {job.robot_id, job.map_id, job.T_map_kf};
    auto& newest = newest_[job.robot_id];
    if (job.node_id >= newest) newest_keyframe_[job.robot_id] = job.keyframe_id;
    newest = std::max(newest, job.node_id);
    if (job.live) insert_ms_.add(ms);
    ++inserted_;
  }
  stream_dirty_ = true;
  if (!job.live) return;
  if (sliceDue(job.robot_id)) publishSlice(job.robot_id);
}

void MapWorker::applyPendingPoses() {
  std::vector<MapNodePose> poses;
  uint64_t epoch = 0;
  {
    std::lock_guard<std::mutex> lock(poses_mutex_);
    poses.swap(pending_poses_);
    epoch = pending_epoch_;
    poses_queued_ = false;
  }
  // This update may be newer than keyframes queued behind it (it replaced the ones before them): they take
  // their poses from it when they come.
  early_poses_.clear();
  early_epoch_ = epoch;
  std::map<int64_t, std::pair<int, SE3>> update;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    for (const MapNodePose& p : poses) {
      const auto it = nodes_.find(p.node_id);
      if (it == nodes_.end()) {
        early_poses_.emplace(p.node_id, p);
        continue;
      }
      it->second.map_id = p.map_id;
      it->second.T_map_kf = p.T_map_kf;
      update.emplace(p.node_id, std::make_pair(p.map_id, p.T_map_kf));
    }
  }
  if (occupancy_.updatePoses(update)) log::debug("map: rebuild scheduled after an optimisation");
}

void MapWorker::publishSlice(const std::string& robot_id) {
  NodeState newest;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    const auto it = newest_.find(robot_id);
    if (it == newest_.end()) return;
    newest = nodes_.at(it->second);
  }
  publishSliceAt(robot_id, newest.map_id, newest.T_map_kf);
}

bool MapWorker::sliceDue(const std::string& robot_id) {
  const double now = nowS();
  const auto last = last_slice_s_.find(robot_id);
  if (last != last_slice_s_.end() && now - last->second < config_.slice_period_s) return false;
  last_slice_s_[robot_id] = now;
  return true;
}

void MapWorker::sliceAt(const std::string& robot_id, int map_id, const SE3& T_map_kf) {
  worker_.post([this, robot_id, map_id, T_map_kf] {
    if (sliceDue(robot_id)) publishSliceAt(robot_id, map_id, T_map_kf);
  });
}

void MapWorker::addScratchKeyframe(MapKeyframeJob job) {
  worker_.post([this, job = std::move(job)]() mutable { insertScratch(job); });
}

void MapWorker::dropScratch(const std::string& robot_id) {
  worker_.post([this, robot_id] { scratch_.erase(robot_id); });
}

void MapWorker::insertScratch(MapKeyframeJob& job) {
  Scratch& scratch = scratch_[job.robot_id];
  if (!scratch.tree || scratch.keyframes >= kScratchKeyframes) {
    OccupancyMapConfig config = config_.occupancy;
    config.spill_dir.clear();  // nothing of it on disk
    scratch.tree = std::make_unique<OccupancyMap>(config);
    scratch.keyframes = 0;
  }
  auto cloud = makerFor(job.robot_id, job.camera)
                   .make(scratch.keyframes, job.depth, job.camera.depth_scale, job.color);
  if (!cloud) return log::warn("map: scratch keyframe of ", job.robot_id, ": ", cloud.error());
  if (const Status s = scratch.tree->insert(std::move(*cloud), 0, job.T_map_kf); !s)
    return log::warn("map: scratch keyframe of ", job.robot_id, ": ", s.error());
  ++scratch.keyframes;
  if (!sliceDue(job.robot_id)) return;
  Result<msg::OccupancySlice> slice = Result<msg::OccupancySlice>::failure("no scratch tree");
  scratch.tree->read(
      0, [&](const octomap::OcTree& tree) { slice = extractSlice(tree, job.T_map_kf, config_.slice); });
  if (!slice) return log::warn("map: scratch slice for ", job.robot_id, ": ", slice.error());
  slice->robot_id = job.robot_id;
  if (publishers_.slice) publishers_.slice(job.robot_id, *slice);
  std::lock_guard<std::mutex> lock(state_mutex_);
  ++slices_sent_;
}

void MapWorker::publishSliceAt(const std::string& robot_id, int map_id, const SE3& T_map_kf) {
  const double cpu0 = threadCpuMs();
  Result<msg::OccupancySlice> slice =
      Result<msg::OccupancySlice>::failure("no tree for map " + std::to_string(map_id));
  occupancy_.read(map_id,
                  [&](const octomap::OcTree& tree) { slice = extractSlice(tree, T_map_kf, config_.slice); });
  if (!slice) {
    log::warn("map: slice for ", robot_id, ": ", slice.error());
    return;
  }
  const double cpu_ms = threadCpuMs() - cpu0;
  slice->robot_id = robot_id;
  if (publishers_.slice) publishers_.slice(robot_id, *slice);
  std::lock_guard<std::mutex> lock(state_mutex_);
  slice_ms_.add(cpu_ms);
  last_slices_[robot_id] = std::move(*slice);
  ++slices_sent_;
}

void MapWorker::onStreamTick() {
  const bool inserted = stream_dirty_ && config_.map_stream_delay_s > 0.0;
  if (inserted || nowS() - last_stream_s_ >= config_.map_stream_period_s - 1e-3) publishStreams();
}

void MapWorker::publishStreams() {
  stream_dirty_ = false;
  last_stream_s_ = nowS();
  std::map<std::string, std::pair<int, int>> map_of;  ///< robot -> (map id, its newest keyframe id)
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    for (const auto& [robot, node] : newest_)
      map_of[robot] = {nodes_.at(node).map_id, newest_keyframe_[robot]};
  }
  // Robots in one map that were sent the same revision get the same bytes: made once per (map, since) and
  // copied (16 robots of a fleet in one map: one serialisation per period instead of 16).
  std::map<std::pair<int, uint64_t>, msg::MapUpdate> made;
  for (const auto& [robot, ids] : map_of) {
    const int map_id = ids.first;
    StreamState& state = streams_[robot];
    const uint64_t since = state.map_id == map_id ? state.revision : 0;
    if (since != 0 && occupancy_.revision(map_id) == since) continue;  // nothing new
    auto it = made.find({map_id, since});
    if (it == made.end()) {
      const auto chunk = occupancy_.streamSince(map_id, since);
      if (!chunk) {
        log::warn("map: stream for ", robot, ": ", chunk.error());
        continue;
      }
      msg::MapUpdate m;
      if (const Status s = fillMapUpdate(*chunk, config_.occupancy.resolution_m, &m); !s) {
        log::warn("map: stream for ", robot, ": ", s.error());
        continue;
      }
      it = made.emplace(std::make_pair(map_id, since), std::move(m)).first;
    }
    msg::MapUpdate update = it->second;
    update.robot_keyframe_id = ids.second;
    if (publishers_.map) publishers_.map(robot, update);
    state.map_id = map_id;
    state.revision = static_cast<uint64_t>(update.map_revision);
    std::lock_guard<std::mutex> lock(state_mutex_);
    ++map_updates_sent_;
    map_bytes_sent_ += update.data.size();
  }
}

void MapWorker::fillStats(MapWorkerStats* s) const {
  const OccupancyMapStats o = occupancy_.stats();
  s->map_tree_memory_bytes = o.tree_memory_bytes;
  s->map_journal_bytes = o.journal_bytes;
  s->map_clouds_memory_bytes = o.clouds_memory_bytes;
  s->map_clouds_spilled = o.clouds_spilled;
  s->map_spill_file_bytes = o.spill_file_bytes;
  s->map_spill_failures = o.spill_failures;
  s->map_leaves = o.leaf_nodes;
  s->map_occupied_leaves = o.occupied_leaves;
  s->map_rebuilds = o.rebuilds;
  s->map_last_rebuild_ms = o.last_rebuild_ms;
  std::lock_guard<std::mutex> lock(state_mutex_);
  s->map_keyframes = inserted_;
  s->map_images_deferred = images_deferred_.load();
  s->map_pose_updates_coalesced = pose_updates_coalesced_.load();
  s->map_insert_ms_median = insert_ms_.median();
  s->slice_ms_median = slice_ms_.median();
  s->slices_sent = slices_sent_;
  s->map_updates_sent = map_updates_sent_;
  s->map_bytes_sent = map_bytes_sent_;
}

}  // namespace rgbdmap
