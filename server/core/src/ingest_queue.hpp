#pragma once
// The ingest worker: one SerialWorker ("rgbdmap-ingest") that runs the pipeline's events in arrival order
// (Hello and Keyframe from the receive thread, optimisation results from the optimiser's thread). Keyframes
// are bounded by ingest_queue_capacity: beyond, they are dropped unacknowledged (the robot resends). A
// periodic tick on the same thread lets the pipeline give up on predecessors that do not come.
// Tracks the submitted and applied optimisation revisions, so that waitIdle() also waits for the solves in
// flight and their corrections.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>

#include "ingest_pipeline.hpp"
#include "rgbdmap/common/serial_worker.hpp"

namespace rgbdmap {

class IngestQueue {
 public:
  /// Every tick_s (> 0) between events, pipeline.onTick() (keyframes waiting too long for a predecessor).
  IngestQueue(size_t keyframe_capacity, double tick_s, IngestPipeline& pipeline);

  void start();
  /// Drops the queued events, waits for the running one; afterwards pushes are ignored. Idempotent.
  void stop();

  void pushHello(msg::Hello hello);
  void pushKeyframe(msg::Keyframe keyframe);
  void pushOptimized(std::shared_ptr<const OptimizedPoses> result);
  /// A snapshot with this revision went to the optimiser (its result will come back through pushOptimized).
  void noteSubmitted(uint64_t revision);

  /// No event queued or running, and every submitted revision applied; false on timeout or once stopped.
  bool waitIdleUntil(std::chrono::steady_clock::time_point deadline) const;
  uint64_t droppedQueueFull() const { return dropped_queue_full_.load(); }

 private:
  bool waitRevisionsUntil(std::chrono::steady_clock::time_point deadline) const;
  bool revisionsApplied() const;  ///< caller holds revision_mutex_

  IngestPipeline& pipeline_;
  std::atomic<uint64_t> dropped_queue_full_{0};
  mutable std::mutex revision_mutex_;
  mutable std::condition_variable revision_cv_;
  uint64_t submitted_revision_ = 0;
  uint64_t applied_revision_ = 0;
  bool stopping_ = false;
  SerialWorker worker_;  ///< last: stopped before the state above goes away
};

}  // namespace rgbdmap
