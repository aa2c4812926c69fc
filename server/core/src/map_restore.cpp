// Restart on the same map directory: robots (cameras), keyframes and loop edges come back from the map
// store into the index, the graph and the loop detector; the map worker re-inserts the keyframes.
#include <chrono>
#include <string>
#include <utility>

#include "ingest_pipeline.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

namespace rgbdmap {

Status IngestPipeline::restore() {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto loaded = registry_.load(store_->directory());
  if (!loaded) return Status::failure(loaded.error());
  for (const ServerRobotStats& r : registry_.stats())
    if (r.camera) {
      detector_.setRobotCamera(registry_.index(r.robot_id), *r.camera);
      setLoaderCamera(r.robot_id, *r.camera);
    }
  const int skipped = restoreKeyframesLocked();
  restoreLoopsLocked();
  counters_.restored_keyframes = counters_.keyframes;
  index_.setComponents(graph_.components());
  if (counters_.keyframes > 0)
    log::info("server: restored ", counters_.keyframes, " keyframes, ", counters_.restored_loops,
              " loops from ", store_->directory(),
              skipped ? " (" + std::to_string(skipped) + " skipped)" : std::string());
  return Status::success();
}

/// Keyframes in store order, which is arrival order: each enters the graph after its predecessor as it did
/// live (the reorder buffer again); those still waiting at the end start new chains at once, before the
/// loop edges that may name them.
int IngestPipeline::restoreKeyframesLocked() {
  int skipped = 0;
  const auto now = std::chrono::steady_clock::now();
  for (const StoredKeyframe& listed : store_->keyframes()) {
    // The in-memory list has no features: each record is read back (and verified again) from disk.
    Result<StoredKeyframe> read = store_->readKeyframe(listed.node_id);
    const auto camera = registry_.camera(listed.keyframe.robot_id);
    auto features = !read ? Result<FrameFeatures>::failure(read.error())
                    : camera
                        ? featuresFromMessage(read->keyframe, PinholeCamera(*camera))
                        : Result<FrameFeatures>::failure("no camera for robot " + listed.keyframe.robot_id);
    const bool in_order = listed.node_id >= next_node_id_;
    if (in_order) next_node_id_ = listed.node_id + 1;  // never reused, even when skipped
    if (!features || !in_order) {
      ++skipped;
      log::error("server: stored keyframe ", listed.node_id,
                 " skipped: ", !in_order ? "node id out of order" : features.error());
      continue;
    }
    noteSeen(keyOf(listed));
    placeLocked({listed, std::move(*features), now}, nullptr, false);
  }
  giveUpWaitingLocked(now, 0.0, false);
  return skipped;
}

void IngestPipeline::restoreLoopsLocked() {
  const std::vector<StoredLoop>& loops = store_->loops();
  for (size_t i = 0; i < loops.size(); ++i) {
    const StoredLoop& loop = loops[i];
    if (!index_.validId(loop.from_node) || !index_.validId(loop.to_node)) {
      log::error("server: stored loop ", loop.from_node, "-", loop.to_node, " names unknown keyframes");
      continue;
    }
    LoopEdge edge;
    edge.from_id = static_cast<int>(loop.from_node);
    edge.to_id = static_cast<int>(loop.to_node);
    edge.T_from_to = loop.T_from_to;
    edge.information = loop.information;
    edge.inliers = loop.inliers;
    edge.motion_measure = loop.motion_measure;
    // The landmark tracks come back with the pairs; without them the edge still constrains the graph.
    if (Result<std::vector<std::pair<int, int>>> pairs = store_->readLoopPairs(i))
      edge.inlier_pairs = std::move(pairs).value();
    else
      log::error("server: stored loop ", loop.from_node, "-", loop.to_node, ": ", pairs.error());
    if (const Status s = addLoopEdgeLocked(edge); !s) {
      log::error("server: stored loop: ", s.error());
      continue;
    }
    detector_.restoreEdge(edge);
    registry_.countLoop(index_.node(edge.from_id).kf.robot_id);
    ++counters_.loops_accepted;
    ++counters_.restored_loops;
  }
}

void IngestPipeline::startFeeding(MapWorker* map_worker) {
  std::lock_guard<std::mutex> lock(mutex_);
  map_worker_ = map_worker;
  for (const IndexedNode& n : index_.nodes()) {
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

}  // namespace rgbdmap
