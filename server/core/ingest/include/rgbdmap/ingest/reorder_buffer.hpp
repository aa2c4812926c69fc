#pragma once
// The ingest pipeline's reorder buffer: keyframes that are stored and acknowledged but wait for their
// odometry predecessor before they enter the pose graph (a retransmission overtook it, or it was lost).
// "Store first, order later": the robot is answered at once, the graph still sees each chain in order.
//
// A waiting keyframe whose predecessor is not waiting itself is the head of a waiting run. A run is given
// up when one of its keyframes has waited reorder_timeout_s, or when its robot has more than
// reorder_capacity keyframes waiting (the oldest run first): its head then starts a new chain, and the
// rest of the run follows it in order. Not thread-safe: the ingest pipeline guards it with its state lock.
#include <chrono>
#include <cstddef>
#include <map>
#include <optional>
#include <vector>

#include "rgbdmap/ingest/keyframe_index.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

struct WaitingKeyframe {
  StoredKeyframe stored;   ///< without images (the map worker reads them back from the store)
  FrameFeatures features;  ///< decoded once, when it arrived
  std::chrono::steady_clock::time_point since;  ///< when it was stored
};

class ReorderBuffer {
 public:
  using Clock = std::chrono::steady_clock;

  /// `key` waits for `predecessor` (the same robot, session and segment).
  void add(const KeyframeKey& key, const KeyframeKey& predecessor, WaitingKeyframe waiting);
  bool contains(const KeyframeKey& key) const { return by_key_.count(key) != 0; }
  /// Removes and returns the keyframes waiting for `predecessor` (normally at most one).
  std::vector<WaitingKeyframe> takeSuccessors(const KeyframeKey& predecessor);
  /// Removes and returns the head of one run to give up on (see above), or nothing. Call until nothing
  /// comes back, integrating each head and then its successors.
  std::optional<WaitingKeyframe> takeRunToGiveUp(Clock::time_point now, double timeout_s, size_t capacity);

  size_t size() const { return by_key_.size(); }
  size_t waiting(int robot) const;  ///< robot index (KeyframeKey's first element)

 private:
  struct Entry {
    KeyframeKey predecessor;
    WaitingKeyframe waiting;
  };
  using EntryMap = std::map<KeyframeKey, Entry>;
  /// The first keyframe of the run `key` is in: its predecessor chain followed back while it waits. In a
  /// (forged) cycle, some member of it.
  KeyframeKey headOf(const KeyframeKey& key) const;
  WaitingKeyframe take(const KeyframeKey& key);
  std::optional<KeyframeKey> oldest(std::optional<int> robot) const;

  EntryMap by_key_;
  std::multimap<KeyframeKey, KeyframeKey> by_predecessor_;  ///< predecessor -> waiting keyframe
};

}  // namespace rgbdmap
