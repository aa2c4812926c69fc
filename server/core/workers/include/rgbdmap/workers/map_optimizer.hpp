#pragma once
// The map optimiser: one worker thread that runs the map back-end (MapBackend: pose graph, landmark map,
// local and global bundle adjustment) on the batches the ingest worker submits. Batches that arrive while it
// works are taken together, each run ends with a result to the callback. When no batch came for
// ba.global_when_idle_s and the back-end has work due (globalDue), the quiet map gets a run of its own.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>

#include "rgbdmap/backend/map_backend.hpp"
#include "rgbdmap/backend/optimizer_batch.hpp"
#include "rgbdmap/common/serial_worker.hpp"

namespace rgbdmap {

struct MapOptimizerConfig {
  PoseGraphConfig graph;
  BundleAdjustmentConfig ba;
  int nice = 0;  ///< the worker thread's nice above the process (server.background_nice)
  /// Where the landmark map takes the keyframes' features from (null: the batches' copies are kept).
  std::shared_ptr<FeatureCache> features;
};

class MapOptimizer {
 public:
  using Callback = std::function<void(const std::shared_ptr<const MapOptimization>&)>;

  MapOptimizer(MapOptimizerConfig config, Callback callback);
  ~MapOptimizer();  ///< stop()
  MapOptimizer(const MapOptimizer&) = delete;
  MapOptimizer& operator=(const MapOptimizer&) = delete;

  /// Queues a batch and returns its revision at once (0 after stop()); its result comes to the callback.
  uint64_t submit(OptimizerBatch batch);
  /// A map changed since its last global BA, or neighbourhood solves since the last whole-graph one (what a
  /// submit with `global` would do something for), as of the last result.
  bool globalDue() const;
  /// Cancels a running solve, drops pending batches and joins the worker. Idempotent.
  void stop();

 private:
  void processPending();  ///< a task on worker_: every pending batch as one
  void onIdle();          ///< worker_'s period: the back-end's run for a quiet map
  void publish(uint64_t revision, std::shared_ptr<MapOptimization> result);

  const double global_when_idle_s_;
  Callback callback_;
  MapBackend backend_;  ///< used on worker_ only (cancel() from stop())

  mutable std::mutex mutex_;  ///< pending_, revisions, stopping_, global_due_
  OptimizerBatch pending_;
  uint64_t pending_revision_ = 0;
  uint64_t next_revision_ = 1;
  bool task_queued_ = false;
  bool stopping_ = false;
  bool global_due_ = false;
  std::chrono::steady_clock::time_point last_batch_ = std::chrono::steady_clock::now();
  SerialWorker worker_;  ///< last: stopped before the state above goes away
};

}  // namespace rgbdmap
