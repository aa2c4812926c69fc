// SerialWorker (rgbdmap_common): order, stop with pending tasks, the bounded queue, waitIdle, the period.
// No sleeps: tasks block on latches the test opens.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "rgbdmap/common/serial_worker.hpp"

namespace rgbdmap {
namespace {

/// A gate a task waits on until the test opens it, and a flag the test waits on until the task entered.
class Latch {
 public:
  void open() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      open_ = true;
    }
    cv_.notify_all();
  }
  bool wait(double timeout_s = 30.0) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [this] { return open_; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool open_ = false;
};

TEST(SerialWorker, RunsTasksInPostingOrder) {
  SerialWorker worker;
  std::vector<int> order;  // written by the worker only; read after waitIdle
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(worker.post([&order, i] { order.push_back(i); }), SerialWorker::Posted::kQueued);
  worker.start();
  ASSERT_TRUE(worker.waitIdle(30.0));
  ASSERT_EQ(order.size(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(order[static_cast<size_t>(i)], i);
}

TEST(SerialWorker, ANicedWorkerRunsNicerThanTheProcessAndItsOwnCallerIsUnchanged) {
  const auto tid = [] { return static_cast<id_t>(syscall(SYS_gettid)); };
  const int process = getpriority(PRIO_PROCESS, tid());
  for (const int nice : {0, 5}) {
    SerialWorkerOptions o;
    o.nice = nice;
    SerialWorker worker(o);
    int seen = -100;
    worker.post([&] { seen = getpriority(PRIO_PROCESS, tid()); });
    worker.start();
    ASSERT_TRUE(worker.waitIdle(30.0));
    EXPECT_EQ(seen, std::min(19, process + nice)) << nice;
  }
  EXPECT_EQ(getpriority(PRIO_PROCESS, tid()), process);
}

TEST(SerialWorker, TasksPostedFromATaskRunAfterIt) {
  SerialWorker worker;
  std::vector<int> order;
  worker.start();
  worker.post([&] {
    order.push_back(1);
    worker.post([&] { order.push_back(3); });
    order.push_back(2);
  });
  ASSERT_TRUE(worker.waitIdle(30.0));  // idle only after the task posted from the task ran
  EXPECT_EQ(order, (std::vector<int>{1, 2, 3}));
}

TEST(SerialWorker, StopFinishesTheRunningTaskAndDropsThePendingOnes) {
  SerialWorker worker;
  Latch entered, release;
  std::atomic<int> ran{0};
  worker.start();
  worker.post([&] {
    entered.open();
    release.wait();
    ++ran;
  });
  for (int i = 0; i < 10; ++i) worker.post([&] { ran += 100; });
  ASSERT_TRUE(entered.wait());
  EXPECT_TRUE(worker.busy());
  EXPECT_EQ(worker.queued(), 10u);
  // waitIdle() returns (false) the moment stop() has begun: only then is the running task released.
  std::thread releaser([&] {
    EXPECT_FALSE(worker.waitIdle(30.0));
    release.open();
  });
  worker.stop();  // blocks until the running task returns
  releaser.join();
  EXPECT_EQ(ran.load(), 1) << "the running task finished, the 10 pending ones were dropped";
  EXPECT_TRUE(worker.stopped());
  EXPECT_EQ(worker.post([] {}), SerialWorker::Posted::kStopped);
  EXPECT_FALSE(worker.waitIdle(0.1)) << "waitIdle is false once stopped";
  worker.stop();  // idempotent
}

TEST(SerialWorker, BoundedQueueRefusesTryPostWhenFullButNotPost) {
  SerialWorkerOptions options;
  options.capacity = 2;
  SerialWorker worker(options);
  Latch entered, release;
  worker.start();
  worker.post([&] {
    entered.open();
    release.wait();
  });
  ASSERT_TRUE(entered.wait());  // the blocking task runs: it no longer occupies the queue
  std::atomic<int> ran{0};
  EXPECT_EQ(worker.tryPost([&] { ++ran; }), SerialWorker::Posted::kQueued);
  EXPECT_EQ(worker.tryPost([&] { ++ran; }), SerialWorker::Posted::kQueued);
  EXPECT_EQ(worker.tryPost([&] { ++ran; }), SerialWorker::Posted::kFull);
  EXPECT_EQ(worker.post([&] { ++ran; }), SerialWorker::Posted::kQueued) << "post() is never refused";
  release.open();
  ASSERT_TRUE(worker.waitIdle(30.0));
  EXPECT_EQ(ran.load(), 3);
  EXPECT_EQ(worker.tryPost([&] { ++ran; }), SerialWorker::Posted::kQueued) << "room again once run";
  ASSERT_TRUE(worker.waitIdle(30.0));
  EXPECT_EQ(ran.load(), 4);
}

TEST(SerialWorker, WaitIdleWaitsForTheRunningTaskAndTimesOut) {
  SerialWorker worker;
  EXPECT_TRUE(worker.waitIdle(0.0)) << "nothing queued: idle even before start";
  worker.post([] {});
  EXPECT_FALSE(worker.waitIdle(0.05)) << "a task waits for start()";
  Latch entered, release;
  worker.post([&] {
    entered.open();
    release.wait();
  });
  worker.start();
  ASSERT_TRUE(entered.wait());
  EXPECT_FALSE(worker.waitIdle(0.05)) << "the task still runs";
  release.open();
  EXPECT_TRUE(worker.waitIdle(30.0));
  EXPECT_FALSE(worker.busy());
  EXPECT_EQ(worker.queued(), 0u);
}

TEST(SerialWorker, PeriodRunsOnTheWorkerBetweenTasks) {
  std::mutex mutex;
  std::condition_variable cv;
  int ticks = 0;
  std::atomic<bool> in_task{false}, overlap{false};
  SerialWorkerOptions options;
  options.period_s = 0.01;
  options.on_period = [&] {
    if (in_task) overlap = true;
    std::lock_guard<std::mutex> lock(mutex);
    ++ticks;
    cv.notify_all();
  };
  SerialWorker worker(options);
  worker.start();
  for (int i = 0; i < 20; ++i)
    worker.post([&] {
      in_task = true;
      in_task = false;
    });
  std::unique_lock<std::mutex> lock(mutex);
  ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(30), [&] { return ticks >= 3; }));
  lock.unlock();
  worker.stop();
  EXPECT_FALSE(overlap.load());
}

}  // namespace
}  // namespace rgbdmap
