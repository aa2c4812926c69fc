#include "rgbdmap/common/serial_worker.hpp"

#include <pthread.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <utility>

namespace rgbdmap {

SerialWorker::SerialWorker(SerialWorkerOptions options) : options_(std::move(options)) {}

SerialWorker::~SerialWorker() { stop(); }

void SerialWorker::start() {
  std::lock_guard<std::mutex> join_lock(join_mutex_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
  }
  if (!thread_.joinable()) thread_ = std::thread([this] { run(); });
}

SerialWorker::Posted SerialWorker::post(Task task) { return enqueue(std::move(task), false); }

SerialWorker::Posted SerialWorker::tryPost(Task task) { return enqueue(std::move(task), true); }

SerialWorker::Posted SerialWorker::enqueue(Task task, bool bounded) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return Posted::kStopped;
    if (bounded && options_.capacity > 0 && bounded_queued_ >= options_.capacity) return Posted::kFull;
    queue_.push_back({std::move(task), bounded});
    if (bounded) ++bounded_queued_;
  }
  wake_.notify_one();
  return Posted::kQueued;
}

void SerialWorker::stop() {
  std::deque<Entry> dropped;  // destroyed outside the lock (tasks may hold large captures)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    dropped.swap(queue_);
    bounded_queued_ = 0;
  }
  wake_.notify_all();
  idle_.notify_all();
  std::lock_guard<std::mutex> join_lock(join_mutex_);
  if (thread_.joinable()) thread_.join();
}

bool SerialWorker::waitIdleUntil(Clock::time_point deadline) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return idle_.wait_until(lock, deadline, [this] { return stopping_ || (queue_.empty() && !busy_); }) &&
         !stopping_;
}

bool SerialWorker::waitIdle(double timeout_s) const {
  return waitIdleUntil(Clock::now() +
                       std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s)));
}

size_t SerialWorker::queued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size();
}

bool SerialWorker::busy() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return busy_;
}

bool SerialWorker::stopped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stopping_;
}

bool SerialWorker::next(Task* task, Clock::time_point next_tick) {
  std::unique_lock<std::mutex> lock(mutex_);
  busy_ = false;
  idle_.notify_all();
  const auto ready = [this] { return stopping_ || !queue_.empty(); };
  if (options_.period_s > 0.0 && options_.on_period)
    wake_.wait_until(lock, next_tick, ready);
  else
    wake_.wait(lock, ready);
  if (stopping_) return false;
  if (!queue_.empty()) {
    *task = std::move(queue_.front().task);
    if (queue_.front().bounded) --bounded_queued_;
    queue_.pop_front();
  }
  busy_ = true;
  return true;
}

void SerialWorker::run() {
  if (!options_.name.empty()) pthread_setname_np(pthread_self(), options_.name.substr(0, 15).c_str());
  if (options_.nice > 0) {  // best effort: a failure leaves the thread at the process's priority
    const auto tid = static_cast<id_t>(syscall(SYS_gettid));
    errno = 0;
    const int current = getpriority(PRIO_PROCESS, tid);
    if (errno == 0) (void)setpriority(PRIO_PROCESS, tid, std::min(19, current + options_.nice));
  }
  const bool periodic = options_.period_s > 0.0 && options_.on_period;
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(periodic ? options_.period_s : 0.0));
  auto next_tick = Clock::now() + period;
  for (;;) {
    Task task;
    if (!next(&task, next_tick)) return;
    if (task) task();
    if (periodic && Clock::now() >= next_tick) {
      options_.on_period();
      next_tick = Clock::now() + period;
    }
  }
}

}  // namespace rgbdmap
