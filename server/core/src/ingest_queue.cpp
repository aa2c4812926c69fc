#include "ingest_queue.hpp"

#include <algorithm>
#include <utility>

namespace rgbdmap {
namespace {

SerialWorkerOptions ingestOptions(size_t keyframe_capacity, double tick_s, IngestPipeline& pipeline) {
  SerialWorkerOptions options;
  options.name = "rgbdmap-ingest";
  options.capacity = keyframe_capacity;  // keyframes only (tryPost); Hello and results always get in
  options.period_s = tick_s;
  options.on_period = [&pipeline] { pipeline.onTick(); };
  return options;
}

}  // namespace

IngestQueue::IngestQueue(size_t keyframe_capacity, double tick_s, IngestPipeline& pipeline)
    : pipeline_(pipeline), worker_(ingestOptions(keyframe_capacity, tick_s, pipeline)) {}

void IngestQueue::start() { worker_.start(); }

void IngestQueue::stop() {
  {
    std::lock_guard<std::mutex> lock(revision_mutex_);
    stopping_ = true;
  }
  revision_cv_.notify_all();
  worker_.stop();
}

void IngestQueue::pushHello(msg::Hello hello) {
  worker_.post([this, hello = std::move(hello)] { pipeline_.onHello(hello); });
}

void IngestQueue::pushKeyframe(msg::Keyframe keyframe) {
  const auto posted =
      worker_.tryPost([this, keyframe = std::move(keyframe)] { pipeline_.onKeyframe(keyframe); });
  if (posted == SerialWorker::Posted::kFull) ++dropped_queue_full_;  // not acknowledged: the robot resends
}

void IngestQueue::pushOptimized(std::shared_ptr<const OptimizedPoses> result) {
  worker_.post([this, result = std::move(result)] {
    pipeline_.onOptimized(*result);
    {
      std::lock_guard<std::mutex> lock(revision_mutex_);
      applied_revision_ = std::max(applied_revision_, result->revision);
    }
    revision_cv_.notify_all();
  });
}

void IngestQueue::noteSubmitted(uint64_t revision) {
  std::lock_guard<std::mutex> lock(revision_mutex_);
  submitted_revision_ = std::max(submitted_revision_, revision);
}

bool IngestQueue::revisionsApplied() const { return applied_revision_ >= submitted_revision_; }

bool IngestQueue::waitRevisionsUntil(std::chrono::steady_clock::time_point deadline) const {
  std::unique_lock<std::mutex> lock(revision_mutex_);
  return revision_cv_.wait_until(lock, deadline, [this] { return stopping_ || revisionsApplied(); }) &&
         !stopping_;
}

bool IngestQueue::waitIdleUntil(std::chrono::steady_clock::time_point deadline) const {
  // Both at once: an event may submit a solve (the worker idles while it runs) and a result is an event.
  for (;;) {
    if (!waitRevisionsUntil(deadline) || !worker_.waitIdleUntil(deadline)) return false;
    std::lock_guard<std::mutex> lock(revision_mutex_);
    if (revisionsApplied()) return true;
  }
}

}  // namespace rgbdmap
