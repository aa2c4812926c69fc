#pragma once
// Runs PoseGraph::optimize on a worker thread so that ingestion never waits for a solve. Callers submit
// snapshots of the graph; a snapshot that arrives while a solve runs replaces any older pending one
// (requests are coalesced, the newest wins). Results carry the revision of the snapshot they solved.
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "rgbdmap/common/serial_worker.hpp"
#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap {

struct OptimizedPoses {
  uint64_t revision = 0;  ///< the submit() number of the snapshot these poses come from
  bool ok = false;
  std::string error;  ///< why the solve failed when !ok
  OptimizeReport report;
  std::map<int64_t, SE3> T_map_kf;
  std::vector<int64_t> disabled_edges;
  std::vector<std::vector<int64_t>> components;
};

class PoseGraphOptimizer {
 public:
  /// Called on the worker thread after each solve; keep it short (copy or post the result).
  using Callback = std::function<void(const std::shared_ptr<const OptimizedPoses>&)>;
  /// Called on the worker thread when a solve of snapshot `revision` starts (tests use it to act on a
  /// running solve); keep it short.
  using SolveStarted = std::function<void(uint64_t revision)>;

  explicit PoseGraphOptimizer(PoseGraphConfig config, Callback callback = {}, SolveStarted on_solve = {});
  ~PoseGraphOptimizer();  ///< stop()
  PoseGraphOptimizer(const PoseGraphOptimizer&) = delete;
  PoseGraphOptimizer& operator=(const PoseGraphOptimizer&) = delete;

  /// Queues a snapshot and returns its revision at once (only a short lock, never a solve). Returns 0
  /// after stop().
  uint64_t submit(PoseGraph snapshot);
  /// The newest finished result, or nullptr before the first one.
  std::shared_ptr<const OptimizedPoses> latestResult() const;
  /// Waits until a result with revision >= `revision` exists; false on timeout or after stop().
  bool waitForRevision(uint64_t revision, double timeout_s) const;
  /// Cancels the running solve, drops the pending snapshot and joins the worker. Idempotent.
  void stop();

 private:
  void solvePending();  ///< a task on worker_: solves the newest pending snapshot, if any

  PoseGraphConfig config_;
  Callback callback_;
  SolveStarted on_solve_;
  mutable std::mutex mutex_;
  mutable std::condition_variable done_;  ///< new result or stop (waitForRevision waits)
  std::optional<PoseGraph> pending_;
  uint64_t pending_revision_ = 0;
  uint64_t next_revision_ = 1;
  bool stopping_ = false;
  std::atomic<bool> cancel_{false};
  std::shared_ptr<const OptimizedPoses> latest_;
  SerialWorker worker_;  ///< last: stopped before the state above goes away
};

}  // namespace rgbdmap
