#include "rgbdmap/ingest/map_restore.hpp"

#include <chrono>
#include <string>
#include <utility>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

namespace rgbdmap {

Status MapRestore::run() {
  const auto loaded = to_.registry.load(store_.directory());
  if (!loaded) return Status::failure(loaded.error());
  for (const ServerRobotStats& r : to_.registry.stats())
    if (r.camera) {
      to_.graph.setRobotCamera(to_.registry.index(r.robot_id), *r.camera);
      to_.loader.setCamera(r.robot_id, *r.camera);
    }
  const int skipped = restoreKeyframes();
  restoreLoops();
  to_.stats.restored_keyframes = to_.stats.keyframes;
  to_.graph.index().setComponents(to_.graph.poseGraph().components());
  if (to_.stats.keyframes > 0)
    log::info("server: restored ", to_.stats.keyframes, " keyframes, ", to_.stats.restored_loops,
              " loops from ", store_.directory(),
              skipped ? " (" + std::to_string(skipped) + " skipped)" : std::string());
  return Status::success();
}

/// Keyframes in store order, which is arrival order: each enters the graph after its predecessor as it did
/// live (the reorder buffer again); those still waiting at the end start new chains at once, before the
/// loop edges that may name them.
int MapRestore::restoreKeyframes() {
  int skipped = 0;
  const auto now = std::chrono::steady_clock::now();
  for (const StoredKeyframe& listed : store_.keyframes()) {
    // The in-memory list has no features: each record is read back (and verified again) from disk.
    Result<StoredKeyframe> read = store_.readKeyframe(listed.node_id);
    const auto camera = to_.registry.camera(listed.keyframe.robot_id);
    auto features = !read ? Result<FrameFeatures>::failure(read.error())
                    : camera
                        ? featuresFromMessage(read->keyframe, PinholeCamera(*camera))
                        : Result<FrameFeatures>::failure("no camera for robot " + listed.keyframe.robot_id);
    const bool in_order = to_.intake.claimRestoredNodeId(listed.node_id);  // never reused, even when skipped
    if (!features || !in_order) {
      ++skipped;
      log::error("server: stored keyframe ", listed.node_id,
                 " skipped: ", !in_order ? "node id out of order" : features.error());
      continue;
    }
    to_.decoder.noteSeen(to_.order.keyOf(listed));
    to_.order.place({listed, std::move(*features), now}, nullptr, false);
  }
  to_.order.giveUpWaiting(now, 0.0, false);
  return skipped;
}

void MapRestore::restoreLoops() {
  const std::vector<StoredLoop>& loops = store_.loops();
  for (size_t i = 0; i < loops.size(); ++i) {
    const StoredLoop& loop = loops[i];
    if (!to_.graph.index().validId(loop.from_node) || !to_.graph.index().validId(loop.to_node)) {
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
    if (Result<std::vector<std::pair<int, int>>> pairs = store_.readLoopPairs(i))
      edge.inlier_pairs = std::move(pairs).value();
    else
      log::error("server: stored loop ", loop.from_node, "-", loop.to_node, ": ", pairs.error());
    if (const Status s = to_.graph.restoreLoopEdge(edge); !s) {
      log::error("server: stored loop: ", s.error());
      continue;
    }
    to_.registry.countLoop(to_.graph.index().node(edge.from_id).kf.robot_id);
    ++to_.stats.loops_accepted;
    ++to_.stats.restored_loops;
  }
}

}  // namespace rgbdmap
