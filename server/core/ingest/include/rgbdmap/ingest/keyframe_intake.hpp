#pragma once
// Keyframe intake, the durable side: a keyframe stored (node ids dense in store order), acknowledged at
// once, and queued as a deferred placement; the store-down handling (a failed store or an unsaved
// robots.txt leaves keyframes unacknowledged, loops that could not be stored go with the next ones). Not
// thread-safe except deferred(): IngestPipeline calls it under its state lock.
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/ingest/ingest_timings.hpp"
#include "rgbdmap/ingest/keyframe_index.hpp"
#include "rgbdmap/ingest/reorder_buffer.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap {

/// Stored and acknowledged, waiting for its placement (loop detection, graph insertion).
struct DeferredKeyframe {
  WaitingKeyframe waiting;
  KeyframeKey key;
  std::optional<DecodedImages> images;  ///< dropped beyond kDeferredWithImages (read back instead)
  KeyframeTiming timing;                ///< of the store part (total_ms, cpu_ms: so far)
};

class KeyframeIntake {
 public:
  /// At most this many wait for placement: beyond, the worker places before it stores more (the robots'
  /// queues fill and they resend: the acknowledgements then follow the loop detection's pace again). At
  /// 16 keyframes/s, 256 is 16 s of the loop detection falling behind; each holds its features (~70 KB)
  /// and, the newest kDeferredWithImages only, its decoded images (~1.5 MB at 640x480; the others' images
  /// the map worker reads back from the store).
  static constexpr size_t kDeferredMax = 256;
  static constexpr size_t kDeferredWithImages = 8;

  /// References must outlive the intake.
  KeyframeIntake(RobotRegistry& registry, IngestStats& stats);

  void attach(MapStore* store) { store_ = store; }
  /// Saves robots.txt after a robot (camera) changed; when it fails, keyframes wait until it is saved.
  void saveRegistry();
  /// False while the store takes no appends (failed; StoreRetry recovers it) or robots.txt could not be
  /// saved: the keyframe is left unacknowledged (counted), so its robot sends it again later.
  bool storeWritable();
  /// The next keyframe's node id.
  int64_t nextNodeId() const { return next_node_id_; }
  /// A restored keyframe's node id: false when out of store order (skipped; the id is never reused).
  bool claimRestoredNodeId(int64_t node_id);
  /// Appends `stored` (node id nextNodeId()); false when the store refused (not acknowledged then).
  bool store(const StoredKeyframe& stored);
  /// Loop edges to the store, with those a failed store kept back.
  void storeLoops(std::vector<StoredLoop> loops);

  /// The deferred queue (in store order).
  bool keepsImages() const { return deferred_.size() < kDeferredWithImages; }
  void defer(DeferredKeyframe deferred);
  std::optional<DeferredKeyframe> takeDeferred();
  std::deque<DeferredKeyframe> takeAllDeferred();
  bool isDeferred(const KeyframeKey& key) const;
  size_t deferredNow() const { return deferred_.size(); }
  /// deferredNow() without the state lock (any thread).
  size_t deferred() const { return deferred_count_.load(std::memory_order_relaxed); }
  /// Placements deferred since the last call.
  size_t takeNewlyDeferred() { return std::exchange(newly_deferred_, 0); }

 private:
  RobotRegistry& registry_;
  IngestStats& stats_;
  MapStore* store_ = nullptr;
  int64_t next_node_id_ = 0;  ///< of the next stored keyframe (node ids are dense in store order)
  std::deque<DeferredKeyframe> deferred_;  ///< at most kDeferredMax: admission scans it for resends
  std::atomic<size_t> deferred_count_{0};  ///< deferred_.size(), read by deferred() without the lock
  size_t newly_deferred_ = 0;
  // A failed store (a full disk): what waits for it to work again.
  bool registry_unsaved_ = false;          ///< robots.txt not written since a robot (camera) changed
  bool store_down_logged_ = false;         ///< one log line per outage
  std::vector<StoredLoop> loops_unsaved_;  ///< in the graph, not stored yet: stored with the next loops
};

}  // namespace rgbdmap
