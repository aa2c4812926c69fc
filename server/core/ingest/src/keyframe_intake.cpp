#include "rgbdmap/ingest/keyframe_intake.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

KeyframeIntake::KeyframeIntake(RobotRegistry& registry, IngestStats& stats)
    : registry_(registry), stats_(stats) {}

void KeyframeIntake::saveRegistry() {
  if (const Status s = registry_.save(store_->directory()); !s) {
    registry_unsaved_ = true;  // saved again before the next keyframe is stored
    log::error("server: ", s.error());
  }
}

bool KeyframeIntake::storeWritable() {
  if (registry_unsaved_ && !store_->health().failed && registry_.save(store_->directory()))
    registry_unsaved_ = false;
  if (!registry_unsaved_ && !store_->health().failed) {
    if (std::exchange(store_down_logged_, false)) log::info("server: storing keyframes again");
    return true;
  }
  ++stats_.keyframes_unacked_store_failed;
  if (!std::exchange(store_down_logged_, true))
    log::warn(
        "server: ",
        registry_unsaved_ ? "robots.txt cannot be saved" : "the map store failed: " + store_->health().error,
        "; keyframes are left unacknowledged until it works again");
  return false;
}

bool KeyframeIntake::claimRestoredNodeId(int64_t node_id) {
  const bool in_order = node_id >= next_node_id_;
  if (in_order) next_node_id_ = node_id + 1;  // never reused, even when skipped
  return in_order;
}

bool KeyframeIntake::store(const StoredKeyframe& stored) {
  if (const Status s = store_->appendKeyframe(stored); !s) {
    log::error("server: cannot store keyframe ", stored.keyframe.keyframe_id, " of ",
               stored.keyframe.robot_id, ": ", s.error());
    return false;
  }
  ++next_node_id_;
  return true;
}

/// One write and one sync for all of a keyframe's loops (a lost loop edge costs accuracy, not data).
/// Loops that could not be stored (a failed store) go with the next ones.
void KeyframeIntake::storeLoops(std::vector<StoredLoop> loops) {
  loops.insert(loops.begin(), loops_unsaved_.begin(), loops_unsaved_.end());
  loops_unsaved_.clear();
  if (const Status s = store_->appendLoops(loops); !s) {
    const bool later = store_->health().failed;
    log::error("server: cannot store ", loops.size(), " loop(s)", later ? ", kept for later: " : ": ",
               s.error());
    if (later) loops_unsaved_ = std::move(loops);
  }
}

void KeyframeIntake::defer(DeferredKeyframe deferred) {
  deferred_.push_back(std::move(deferred));
  deferred_count_.store(deferred_.size(), std::memory_order_relaxed);
  stats_.keyframes_deferred_max = std::max(stats_.keyframes_deferred_max, static_cast<int>(deferred_.size()));
  ++newly_deferred_;
}

std::optional<DeferredKeyframe> KeyframeIntake::takeDeferred() {
  if (deferred_.empty()) return std::nullopt;
  DeferredKeyframe d = std::move(deferred_.front());
  deferred_.pop_front();
  deferred_count_.store(deferred_.size(), std::memory_order_relaxed);
  return d;
}

std::deque<DeferredKeyframe> KeyframeIntake::takeAllDeferred() {
  std::deque<DeferredKeyframe> all = std::exchange(deferred_, {});
  deferred_count_.store(0, std::memory_order_relaxed);
  return all;
}

bool KeyframeIntake::isDeferred(const KeyframeKey& key) const {
  return std::any_of(deferred_.begin(), deferred_.end(),
                     [&](const DeferredKeyframe& d) { return d.key == key; });
}

}  // namespace rgbdmap
