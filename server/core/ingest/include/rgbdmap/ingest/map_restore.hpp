#pragma once
// Restart on the same map directory: robots (cameras), keyframes and loop edges come back from the map
// store into the index, the graph and the loop detector, in store order through the chain order as they
// came live. Runs once, under IngestPipeline's state lock, before the ingest worker starts.
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/ingest/chain_order.hpp"
#include "rgbdmap/ingest/feature_loader.hpp"
#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/ingest/keyframe_decoder.hpp"
#include "rgbdmap/ingest/keyframe_intake.hpp"
#include "rgbdmap/ingest/map_graph.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap {

/// The parts a restore fills.
struct RestoreTargets {
  RobotRegistry& registry;
  MapGraph& graph;
  ChainOrder& order;
  KeyframeIntake& intake;
  KeyframeDecoder& decoder;
  FeatureLoader& loader;
  IngestStats& stats;
};

class MapRestore {
 public:
  MapRestore(const MapStore& store, RestoreTargets targets) : store_(store), to_(targets) {}
  /// Robots, keyframes, loop edges; fails only when robots.txt cannot be read.
  Status run();

 private:
  int restoreKeyframes();  ///< returns the number skipped; keyframes may be stored out of chain order
  void restoreLoops();

  const MapStore& store_;
  RestoreTargets to_;
};

}  // namespace rgbdmap
