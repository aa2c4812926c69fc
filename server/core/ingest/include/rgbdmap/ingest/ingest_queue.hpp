#pragma once
// The ingest worker: one SerialWorker ("rgbdmap-ingest") that runs the pipeline's events one at a time.
// Each posted task serves one event, chosen when it runs (fair share):
//   1. a robot's Hello (at most one pending per robot: a newer one replaces it), so a session never waits
//      behind keyframes;
//   2. keyframes to store and acknowledge (unless IngestPipeline::kDeferredMax placements wait), from
//      per-robot bounded queues served round-robin (RobotQueues): a robot flooding the server fills only
//      its own queue, and is served after the robots within their share for a while.
//      A keyframe that does not fit is dropped unacknowledged (the robot resends it) and counted.
//      A second worker ("rgbdmap-decode") takes them from RobotQueues in that order and decodes them
//      (images, features: IngestPipeline::prepare) while the ingest worker integrates the one before; at
//      most kDecodedAhead decoded keyframes wait for the ingest worker (their images are ~1.5 MB each), so
//      the rest wait, encoded and fairly bounded, in RobotQueues.
//   3. the newest optimisation result (it holds every pose: one not applied yet is replaced);
//   4. the placement of the oldest stored keyframe (loop detection, pose graph, map worker). Stored and
//      acknowledged keyframes go before it, so that an acknowledgement waits for the one placement in
//      progress, not for the loop detection of every keyframe queued ahead (the 16-robot fleet run:
//      ack p90 1.7 s in the minute the loop detection fell behind for ~30 s).
// A periodic tick on the same thread lets the pipeline give up on predecessors that do not come.
// Tracks the submitted and applied optimisation revisions, so that waitIdle() also waits for the solves in
// flight and their corrections.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>

#include "rgbdmap/common/serial_worker.hpp"
#include "rgbdmap/ingest/ingest_pipeline.hpp"
#include "rgbdmap/intake/robot_queues.hpp"

namespace rgbdmap {

class IngestQueue {
 public:
  enum class Pushed { kQueued, kFull, kDuplicate, kStopped };

  /// Every tick_s (> 0) between events, pipeline.onTick() (keyframes waiting too long for a predecessor).
  IngestQueue(RobotQueueLimits limits, double tick_s, IngestPipeline& pipeline);

  void start();
  /// Drops the queued events, waits for the running one; afterwards pushes are ignored. Idempotent.
  void stop();

  void pushHello(msg::Hello hello);
  /// `bytes`: its encoded size (the per-robot byte bound). kFull: not queued (the caller counts it);
  /// kDuplicate: the same keyframe is queued already (RobotQueues), answered when that one is served.
  Pushed pushKeyframe(msg::Keyframe keyframe, size_t bytes);
  /// `robot` went over its share (throttled, or its queue was full): served after the other robots for
  /// kDemotionS (RobotQueues).
  void demote(const std::string& robot);
  static constexpr double kDemotionS = 5.0;
  static constexpr size_t kDecodedAhead = 2;
  void pushOptimized(std::shared_ptr<const MapOptimization> result);
  /// A snapshot with this revision went to the optimiser (its result will come back through pushOptimized).
  void noteSubmitted(uint64_t revision);

  /// No event queued or running, and every submitted revision applied; false on timeout or once stopped.
  bool waitIdleUntil(std::chrono::steady_clock::time_point deadline) const;
  /// Keyframes of `robot` queued now, and the most it has had queued at once.
  size_t queued(const std::string& robot) const;
  size_t queuedHighWater(const std::string& robot) const;

 private:
  using Task = std::function<void()>;
  /// Posts one "serve the next event" task; false once stopped. Caller holds events_mutex_.
  bool postServeLocked();
  void serveNext();                                    ///< on the worker
  void serveOne();                                     ///< the event serveNext() serves
  void storeNext(std::unique_lock<std::mutex>& lock);  ///< the next decoded keyframe (lock: events_mutex_)
  void decodeNext();  ///< on the decode worker: one keyframe from RobotQueues, decoded, to decoded_
  void applyResult(const std::shared_ptr<const MapOptimization>& result);
  bool waitRevisionsUntil(std::chrono::steady_clock::time_point deadline) const;
  bool revisionsApplied() const;  ///< caller holds revision_mutex_

  IngestPipeline& pipeline_;

  mutable std::mutex events_mutex_;                ///< the events below
  std::map<std::string, msg::Hello> hellos_;       ///< the latest pending Hello per robot
  std::deque<std::string> hello_order_;            ///< robots with a pending Hello, oldest first
  std::shared_ptr<const MapOptimization> result_;  ///< the newest optimisation result not applied yet
  RobotQueues keyframes_;                          ///< waiting for the decode worker
  std::deque<IngestPipeline::Prepared> decoded_;   ///< decoded, waiting for the ingest worker
  std::condition_variable decoded_room_;           ///< decoded_ has room (or stopped)
  bool events_stopped_ = false;

  mutable std::mutex revision_mutex_;
  mutable std::condition_variable revision_cv_;
  uint64_t submitted_revision_ = 0;
  uint64_t applied_revision_ = 0;
  bool stopping_ = false;
  SerialWorker worker_;         ///< last: stopped before the state above goes away
  SerialWorker decode_worker_;  ///< stopped before worker_ (it posts to it)
};

}  // namespace rgbdmap
