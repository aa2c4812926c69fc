#include "rgbdmap/ingest/ingest_queue.hpp"

#include <algorithm>
#include <utility>

namespace rgbdmap {
namespace {

SerialWorkerOptions ingestOptions(double tick_s, IngestPipeline& pipeline) {
  SerialWorkerOptions options;
  options.name = "rgbdmap-ingest";
  options.capacity = 0;  // one task per queued event; the events are bounded here (RobotQueues, hellos)
  options.period_s = tick_s;
  options.on_period = [&pipeline] { pipeline.onTick(); };
  return options;
}

}  // namespace

IngestQueue::IngestQueue(RobotQueueLimits limits, double tick_s, IngestPipeline& pipeline)
    : pipeline_(pipeline),
      keyframes_(limits),
      worker_(ingestOptions(tick_s, pipeline)),
      decode_worker_(SerialWorkerOptions{"rgbdmap-decode", 0, 0.0, {}}) {}

void IngestQueue::start() {
  worker_.start();
  decode_worker_.start();
}

void IngestQueue::stop() {
  {
    std::lock_guard<std::mutex> lock(events_mutex_);
    events_stopped_ = true;
    hellos_.clear();
    hello_order_.clear();
    result_.reset();
    keyframes_.clear();
    decoded_.clear();
  }
  decoded_room_.notify_all();
  decode_worker_.stop();
  {
    std::lock_guard<std::mutex> lock(revision_mutex_);
    stopping_ = true;
  }
  revision_cv_.notify_all();
  worker_.stop();
}

bool IngestQueue::postServeLocked() {
  if (events_stopped_) return false;
  return worker_.post([this] { serveNext(); }) == SerialWorker::Posted::kQueued;
}

void IngestQueue::pushHello(msg::Hello hello) {
  std::lock_guard<std::mutex> lock(events_mutex_);
  if (events_stopped_) return;
  const std::string robot = hello.robot_id;
  const bool pending = hellos_.count(robot) > 0;
  hellos_[robot] = std::move(hello);  // the newest camera and session win
  if (pending) return;                // already has its task
  hello_order_.push_back(robot);
  postServeLocked();
}

IngestQueue::Pushed IngestQueue::pushKeyframe(msg::Keyframe keyframe, size_t bytes) {
  std::lock_guard<std::mutex> lock(events_mutex_);
  if (events_stopped_) return Pushed::kStopped;
  const std::string robot = keyframe.robot_id;
  switch (keyframes_.push(robot, std::move(keyframe), bytes)) {
    case RobotQueues::Pushed::kFull:
      return Pushed::kFull;  // the robot resends it
    case RobotQueues::Pushed::kDuplicate:
      return Pushed::kDuplicate;
    case RobotQueues::Pushed::kQueued:
      break;
  }
  decode_worker_.post([this] { decodeNext(); });
  return Pushed::kQueued;
}

void IngestQueue::demote(const std::string& robot) {
  const auto until =
      std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                             std::chrono::duration<double>(kDemotionS));
  std::lock_guard<std::mutex> lock(events_mutex_);
  keyframes_.demote(robot, until);
}

void IngestQueue::pushOptimized(std::shared_ptr<const MapOptimization> result) {
  std::lock_guard<std::mutex> lock(events_mutex_);
  if (events_stopped_) return;
  // Each result holds every pose: a newer one replaces one not applied yet (its serve task takes it).
  if (!std::exchange(result_, std::move(result))) postServeLocked();
}

void IngestQueue::applyResult(const std::shared_ptr<const MapOptimization>& result) {
  pipeline_.onOptimized(*result);
  {
    std::lock_guard<std::mutex> revision_lock(revision_mutex_);
    applied_revision_ = std::max(applied_revision_, result->revision);
  }
  revision_cv_.notify_all();
}

/// One event (each has its own task): a pending Hello first, then the next robot's keyframe to store and
/// acknowledge (unless kDeferredMax placements wait), then an optimisation result, then the oldest
/// deferred placement (loop detection, graph).
void IngestQueue::serveNext() {
  serveOne();
  // A stored keyframe's placement is an event of its own (also those a Hello let in).
  const size_t deferred = pipeline_.takeNewlyDeferred();
  std::lock_guard<std::mutex> lock(events_mutex_);
  for (size_t i = 0; i < deferred; ++i) postServeLocked();
}

void IngestQueue::serveOne() {
  std::unique_lock<std::mutex> lock(events_mutex_);
  if (!hello_order_.empty()) {
    const auto it = hellos_.find(hello_order_.front());
    hello_order_.pop_front();
    msg::Hello hello = std::move(it->second);
    hellos_.erase(it);
    lock.unlock();
    return pipeline_.onHello(hello);
  }
  const bool room = pipeline_.deferred() < IngestPipeline::kDeferredMax;
  if (!decoded_.empty() && room) return storeNext(lock);
  if (result_) {
    const std::shared_ptr<const MapOptimization> result = std::exchange(result_, nullptr);
    lock.unlock();
    return applyResult(result);
  }
  lock.unlock();
  if (pipeline_.placeDeferred()) return;
  lock.lock();
  if (!decoded_.empty()) storeNext(lock);  // else dropped by stop()
}

void IngestQueue::storeNext(std::unique_lock<std::mutex>& lock) {
  IngestPipeline::Prepared prepared = std::move(decoded_.front());
  decoded_.pop_front();
  lock.unlock();
  decoded_room_.notify_all();
  pipeline_.onKeyframe(std::move(prepared));
}

/// One task per queued keyframe: waits for room in decoded_, then decodes the next keyframe in fair order.
void IngestQueue::decodeNext() {
  std::unique_lock<std::mutex> lock(events_mutex_);
  decoded_room_.wait(lock, [this] { return events_stopped_ || decoded_.size() < kDecodedAhead; });
  if (events_stopped_) return;
  std::optional<msg::Keyframe> keyframe = keyframes_.pop();
  lock.unlock();
  if (!keyframe) return;
  IngestPipeline::Prepared prepared = pipeline_.prepare(std::move(*keyframe));
  lock.lock();
  if (events_stopped_) return;
  decoded_.push_back(std::move(prepared));
  postServeLocked();
}

size_t IngestQueue::queued(const std::string& robot) const {
  std::lock_guard<std::mutex> lock(events_mutex_);
  return keyframes_.size(robot);
}

size_t IngestQueue::queuedHighWater(const std::string& robot) const {
  std::lock_guard<std::mutex> lock(events_mutex_);
  return keyframes_.highWater(robot);
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
    // The decode worker first: what it decodes becomes an event of the ingest worker (never the reverse).
    if (!waitRevisionsUntil(deadline) || !decode_worker_.waitIdleUntil(deadline) ||
        !worker_.waitIdleUntil(deadline))
      return false;
    std::lock_guard<std::mutex> lock(revision_mutex_);
    if (revisionsApplied()) return true;
  }
}

}  // namespace rgbdmap
