#pragma once
// Chain order: "store first, order later". A stored and acknowledged keyframe enters the graph once its
// odometry predecessor is there; until then it waits in the reorder buffer. A predecessor that does not
// come (robot died, retransmissions given up, reorder bound or timeout) or was refused: the waiting
// keyframes start a new chain (MapGraph places it by the odometry of its segment and joins it when the
// predecessor comes after all). Not thread-safe: IngestPipeline calls it under its state lock.
#include <chrono>
#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include "rgbdmap/ingest/keyframe_index.hpp"
#include "rgbdmap/ingest/reorder_buffer.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/proto/codec.hpp"

namespace rgbdmap {

class ChainOrder {
 public:
  /// Takes one keyframe into the graph: `images` (or null: read back), `live`: received now or restored.
  using Integrate =
      std::function<void(const WaitingKeyframe& waiting, const DecodedImages* images, bool live)>;

  /// References must outlive the order. `index`: what is in the graph (or refused).
  ChainOrder(RobotRegistry& registry, const KeyframeIndex& index, int reorder_capacity, Integrate integrate);

  /// A stored keyframe into the graph now (its predecessor is there, refused, or it has none), followed by
  /// the keyframes that waited for it; or into the reorder buffer. `live`: received now (counted as out of
  /// order when it waits) or restored.
  void place(WaitingKeyframe waiting, const DecodedImages* images, bool live);
  /// `first` into the graph, then every keyframe that waited for it, transitively.
  void integrateWithSuccessors(WaitingKeyframe first, const DecodedImages* images, bool live);
  /// Runs given up on (timeout_s, the reorder capacity) start new chains.
  void giveUpWaiting(std::chrono::steady_clock::time_point now, double timeout_s, bool live);
  /// The keyframe `key` was refused: those waiting for it start a new chain.
  void predecessorRefused(const KeyframeKey& key);

  bool contains(const KeyframeKey& key) const { return reorder_.contains(key); }
  size_t waiting() const { return reorder_.size(); }
  size_t waiting(int robot) const { return reorder_.waiting(robot); }
  KeyframeKey keyOf(const StoredKeyframe& stored) const;

 private:
  std::optional<KeyframeKey> predecessorOf(const StoredKeyframe& stored) const;

  RobotRegistry& registry_;
  const KeyframeIndex& index_;
  const int reorder_capacity_;
  Integrate integrate_;
  ReorderBuffer reorder_;
};

}  // namespace rgbdmap
