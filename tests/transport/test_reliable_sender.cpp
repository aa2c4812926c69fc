// ReliableSender: backoff schedule, retransmission timing, queue bound, acks, prompt stop; DedupFilter.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "rgbdmap/transport/reliable.hpp"

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

double ms(std::chrono::nanoseconds d) { return std::chrono::duration<double, std::milli>(d).count(); }

/// Records every send() call with its time.
struct SendLog {
  std::mutex mutex;
  std::map<uint64_t, std::vector<Clock::time_point>> sends;
  ReliableSender::SendFn fn() {
    return [this](uint64_t id) {
      std::lock_guard<std::mutex> lock(mutex);
      sends[id].push_back(Clock::now());
      return Status::success();
    };
  }
  size_t count(uint64_t id) {
    std::lock_guard<std::mutex> lock(mutex);
    return sends[id].size();
  }
};

TEST(TransportReliableSender, BackoffGrowsExponentiallyUpToTheCapWithBoundedJitter) {
  ReliableSenderOptions o;
  o.initial_backoff = 100ms;
  o.max_backoff = 1000ms;
  o.backoff_factor = 2.0;
  o.jitter = 0.25;
  const double expected[] = {100, 200, 400, 800, 1000, 1000};
  for (int attempt = 1; attempt <= 6; ++attempt) {
    EXPECT_NEAR(ms(ReliableSender::backoff(o, attempt, 0.0)), expected[attempt - 1], 1e-6);
    EXPECT_NEAR(ms(ReliableSender::backoff(o, attempt, 1.0)), 1.25 * expected[attempt - 1], 1e-6);
    EXPECT_NEAR(ms(ReliableSender::backoff(o, attempt, -1.0)), 0.75 * expected[attempt - 1], 1e-6);
  }
}

TEST(TransportReliableSender, RetransmitsWithGrowingGapsThenGivesUp) {
  ReliableSenderOptions o;
  o.initial_backoff = 20ms;
  o.max_backoff = 160ms;
  o.jitter = 0.0;
  o.max_attempts = 5;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  ASSERT_TRUE(sender.submit(7));
  ASSERT_TRUE(sender.waitUntilEmpty(3s));  // given up after 5 sends: 20+40+80+160 ms
  const auto& t = log.sends[7];
  ASSERT_EQ(t.size(), 5u);
  const double expected[] = {20, 40, 80, 160};
  for (size_t i = 1; i < t.size(); ++i) {
    const double gap = ms(t[i] - t[i - 1]);
    // Never early; how late depends on the machine's load, so there is no upper bound here (the exact
    // schedule is checked deterministically by BackoffGrowsExponentiallyUpToTheCapWithBoundedJitter).
    EXPECT_GE(gap, expected[i - 1] - 1.0) << i;
  }
  const auto s = sender.stats();
  EXPECT_EQ(s.retransmissions, 4u);
  EXPECT_EQ(s.given_up, 1u);
  EXPECT_EQ(s.acked, 0u);
}

TEST(TransportReliableSender, QueueIsBoundedAndAckFreesASlot) {
  ReliableSenderOptions o;
  o.max_pending = 4;
  SendLog log;
  ReliableSender sender(o, log.fn());
  for (uint64_t id = 0; id < 4; ++id) ASSERT_TRUE(sender.submit(id));
  EXPECT_FALSE(sender.submit(4));
  EXPECT_FALSE(sender.submit(2));  // already pending
  EXPECT_EQ(sender.stats().dropped_when_full, 1u);
  EXPECT_FALSE(sender.waitForCapacity(10ms));
  EXPECT_TRUE(sender.acknowledge(2));
  EXPECT_FALSE(sender.acknowledge(2));
  EXPECT_TRUE(sender.waitForCapacity(0ms));
  EXPECT_TRUE(sender.submit(4));
  EXPECT_EQ(sender.pending(), 4u);
  EXPECT_EQ(log.count(4), 1u);  // sent at once by submit()
}

TEST(TransportReliableSender, AcknowledgedIdsAreNotRetransmitted) {
  ReliableSenderOptions o;
  o.initial_backoff = 20ms;
  o.jitter = 0.0;
  o.max_attempts = 3;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  ASSERT_TRUE(sender.submit(1));
  ASSERT_TRUE(sender.submit(2));
  EXPECT_TRUE(sender.acknowledge(1));
  ASSERT_TRUE(sender.waitUntilEmpty(2s));  // id 2 is given up after 20 + 40 ms
  EXPECT_EQ(log.count(1), 1u);
  EXPECT_EQ(log.count(2), 3u);
  EXPECT_EQ(sender.stats().acked, 1u);
}

TEST(TransportReliableSender, StopIsPromptWithFarDeadlines) {
  ReliableSenderOptions o;
  o.initial_backoff = 10s;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  ASSERT_TRUE(sender.submit(1));
  const auto t0 = Clock::now();
  sender.stop();
  EXPECT_LT(ms(Clock::now() - t0), 2000.0);  // far below the 10 s deadline it would otherwise wait for
  EXPECT_EQ(sender.pending(), 1u);
  sender.stop();  // idempotent
}

TEST(TransportReliableSender, ConcurrentSubmitAndAck) {
  ReliableSenderOptions o;
  o.max_pending = 10000;
  o.initial_backoff = 1ms;
  o.max_backoff = 4ms;
  o.max_attempts = 1 << 30;
  ReliableSender sender(o, [](uint64_t) { return Status::success(); });
  sender.start();
  std::vector<std::thread> threads;
  for (uint64_t t = 0; t < 4; ++t) {
    threads.emplace_back([&sender, t] {
      for (uint64_t i = 0; i < 500; ++i) {
        const uint64_t id = t * 1000 + i;
        EXPECT_TRUE(sender.submit(id));
        if (i >= 10) sender.acknowledge(id - 10);
      }
      for (uint64_t i = 490; i < 500; ++i) sender.acknowledge(t * 1000 + i);
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(sender.pending(), 0u);
  EXPECT_EQ(sender.stats().acked, 2000u);
}

TEST(TransportDedupFilter, AcceptsEachPairOnce) {
  DedupFilter f;
  EXPECT_TRUE(f.accept(1, 10));
  EXPECT_FALSE(f.accept(1, 10));
  EXPECT_TRUE(f.accept(2, 10));  // other sender
  EXPECT_TRUE(f.accept(1, 11));
  EXPECT_EQ(f.duplicates(), 1u);
}

TEST(TransportDedupFilter, MemoryIsBounded) {
  DedupOptions o;
  o.ids_per_sender = 8;
  o.max_senders = 4;
  DedupFilter f(o);
  for (uint64_t sender = 0; sender < 10; ++sender) {
    for (uint64_t id = 0; id < 100; ++id) EXPECT_TRUE(f.accept(sender, id));
    EXPECT_FALSE(f.accept(sender, 99));  // recent ids are remembered
  }
  EXPECT_LE(f.remembered(), 4u * 8u);
  EXPECT_TRUE(f.accept(9, 0));  // forgotten: older than the window
}

}  // namespace
}  // namespace rgbdmap::transport
