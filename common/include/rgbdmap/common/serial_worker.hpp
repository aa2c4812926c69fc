#pragma once
// One thread that runs queued tasks one at a time, in the order they were posted: the queue + condition
// variable + stop flag that every worker of the server needs, written once. Optionally
//   - bounded: tryPost() refuses a task while `capacity` tryPost() tasks wait (post() is never refused);
//   - periodic: on_period runs on the same thread every period_s, between tasks (never concurrently).
// stop() drops the tasks that have not started, lets the running one finish and joins. waitIdle() blocks on
// a condition variable (no polling) until the queue is empty and nothing runs.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace rgbdmap {

struct SerialWorkerOptions {
  std::string name;       ///< thread name (at most 15 characters are used); empty: not named
  size_t capacity = 0;    ///< tryPost() tasks that may wait; 0 = unbounded
  double period_s = 0.0;  ///< > 0 with on_period: on_period runs every period_s (first after one period)
  std::function<void()> on_period;
  /// > 0: the thread runs this much nicer than the process (Linux: nice is per thread), so that under
  /// overload the threads that are not niced get the cores first; the work here queues and batches instead.
  int nice = 0;
};

class SerialWorker {
 public:
  using Task = std::function<void()>;
  using Clock = std::chrono::steady_clock;
  enum class Posted { kQueued, kFull, kStopped };

  explicit SerialWorker(SerialWorkerOptions options = {});
  ~SerialWorker();  ///< stop()
  SerialWorker(const SerialWorker&) = delete;
  SerialWorker& operator=(const SerialWorker&) = delete;

  /// Starts the thread; tasks posted before wait for it. No effect when running or stopped.
  void start();
  /// Queues a task (also from a task on this worker). kStopped after stop().
  Posted post(Task task);
  /// As post(), but kFull while `capacity` tryPost() tasks wait (unbounded when capacity is 0).
  Posted tryPost(Task task);
  /// Drops the tasks that have not started, waits for the running one and joins. Idempotent; not from a task.
  void stop();

  /// Until the queue is empty and no task (or on_period) runs; false on timeout or once stopped.
  bool waitIdleUntil(Clock::time_point deadline) const;
  bool waitIdle(double timeout_s) const;
  size_t queued() const;  ///< tasks waiting (not the running one)
  bool busy() const;      ///< a task or on_period is running
  bool stopped() const;

 private:
  struct Entry {
    Task task;
    bool bounded = false;
  };
  Posted enqueue(Task task, bool bounded);
  /// Waits for the next task or the period; false when stopping. Sets busy_ when it returns true.
  bool next(Task* task, Clock::time_point next_tick);
  void run();

  const SerialWorkerOptions options_;
  mutable std::mutex mutex_;
  mutable std::condition_variable wake_, idle_;
  std::deque<Entry> queue_;
  size_t bounded_queued_ = 0;
  bool busy_ = false;
  bool stopping_ = false;
  std::mutex join_mutex_;
  std::thread thread_;
};

}  // namespace rgbdmap
