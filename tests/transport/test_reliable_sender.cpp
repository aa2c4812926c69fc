// ReliableSender: backoff schedule, retransmission timing, queue bound, acks, prompt stop; DedupFilter.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include "rgbdmap/transport/reliable.hpp"

#include "transport/reliable_test_util.hpp"

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;
using testing::Clock;
using testing::ms;
using testing::SendLog;

TEST(TransportReliableSender, BackoffGrowsExponentiallyUpToTheCapWithBoundedJitter) {
  ReliableSenderOptions o;
  o.initial_backoff = 100ms;
  o.max_backoff = 1000ms;
  o.backoff_factor = 2.0;
  o.jitter = 0.25;
  const double expected[] = {100, 200, 400, 800, 1000, 1000};
  const std::chrono::nanoseconds rto = ReliableSender::rto(o, {});  // no sample: initial_backoff
  std::chrono::nanoseconds delay = rto;
  for (int attempt = 1; attempt <= 6; ++attempt) {
    if (attempt > 1) delay = ReliableSender::backedOff(o, delay, rto);
    EXPECT_NEAR(ms(delay), expected[attempt - 1], 1e-6);
    EXPECT_NEAR(ms(ReliableSender::jittered(o, delay, 1.0)), 1.25 * expected[attempt - 1], 1e-6);
    EXPECT_NEAR(ms(ReliableSender::jittered(o, delay, -1.0)), 0.75 * expected[attempt - 1], 1e-6);
  }
  // An id's backoff never falls below the sender's RTO now (e.g. raised by a sample since) nor exceeds the
  // cap.
  EXPECT_NEAR(ms(ReliableSender::backedOff(o, 100ms, 500ms)), 500.0, 1e-6);
  EXPECT_NEAR(ms(ReliableSender::backedOff(o, 800ms, 100ms)), 1000.0, 1e-6);
}

TEST(TransportReliableSender, ResendAllNowSendsEveryPendingIdAtOnceAndRestartsItsAttempts) {
  ReliableSenderOptions o;
  o.initial_backoff = o.max_backoff = 10s;  // no retransmission within the test but the ones asked for
  o.adaptive = false;
  o.max_attempts = 2;
  SendLog log;
  std::atomic<int> given_up{0};
  ReliableSender sender(o, log.fn(), [&](uint64_t) { ++given_up; });
  sender.start();
  ASSERT_TRUE(sender.submit(1));
  ASSERT_TRUE(sender.submit(2));
  ASSERT_TRUE(sender.acknowledge(2));
  const Clock::time_point asked = Clock::now();
  for (int round = 1; round <= 3; ++round) {  // beyond max_attempts: each round starts the count again
    sender.resendAllNow();
    for (int i = 0; i < 500 && log.count(1) < static_cast<size_t>(1 + round); ++i)
      std::this_thread::sleep_for(2ms);  // bounded: 1 s
    ASSERT_EQ(log.count(1), static_cast<size_t>(1 + round));
  }
  EXPECT_LT(ms(Clock::now() - asked), 1000.0);
  EXPECT_EQ(log.count(2), 1u);  // acknowledged: not sent again
  EXPECT_EQ(given_up.load(), 0);
  EXPECT_EQ(sender.pending(), 1u);
  EXPECT_EQ(sender.stats().retransmissions, 3u);
  sender.stop();
}

/// RFC 6298 2.2-2.3 by hand (alpha 1/8, beta 1/4, K 4, G 10 ms), samples in ms.
TEST(TransportReliableSender, RetransmitsWithGrowingGapsThenGivesUp) {
  ReliableSenderOptions o;
  o.initial_backoff = 20ms;
  o.max_backoff = 160ms;
  o.jitter = 0.0;
  o.max_attempts = 5;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  const Clock::time_point submitted = Clock::now();
  ASSERT_TRUE(sender.submit(7));
  ASSERT_TRUE(sender.waitUntilEmpty(3s));  // given up after 5 sends: 20+40+80+160 ms
  const auto& t = log.sends[7];
  ASSERT_EQ(t.size(), 5u);
  // Send i is due 20+40+...(i terms) ms after the submission. Never early; how late depends on the
  // machine's load, so there is no upper bound here (the exact schedule is checked deterministically by
  // BackoffGrowsExponentiallyUpToTheCapWithBoundedJitter). Measured from the submission, not between two
  // logged sends: a send logged late (the log's clock is read after the sender's) would shorten the next
  // gap without the sender being early (seen under ASan: 18.5 ms for 20).
  const double due[] = {0, 20, 60, 140, 300};
  for (size_t i = 1; i < t.size(); ++i) EXPECT_GE(ms(t[i] - submitted), due[i]) << i;
  const auto s = sender.stats();
  EXPECT_EQ(s.retransmissions, 4u);
  EXPECT_EQ(s.given_up, 1u);
  EXPECT_EQ(s.acked, 0u);
}

TEST(TransportReliableSender, ZeroMaxAttemptsResendsUntilAcknowledged) {
  ReliableSenderOptions o;
  o.initial_backoff = 1ms;
  o.min_backoff = 1ms;
  o.max_backoff = 2ms;
  o.max_attempts = 0;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  ASSERT_TRUE(sender.submit(1));
  const auto deadline = Clock::now() + 5s;
  while (log.count(1) < 30 && Clock::now() < deadline) std::this_thread::sleep_for(5ms);
  EXPECT_GE(log.count(1), 30u) << "more than the default 20 attempts";
  EXPECT_EQ(sender.stats().given_up, 0u);
  EXPECT_EQ(sender.pending(), 1u);
  EXPECT_TRUE(sender.acknowledge(1));
}

TEST(TransportReliableSender, ProgressIsAnRttSampleRestartsTheTimeoutAndTheAttemptCount) {
  ReliableSenderOptions o;
  o.initial_backoff = 2000ms;  // no sample yet: every id would wait 2 s
  o.min_backoff = 20ms;
  o.max_backoff = 2000ms;
  o.jitter = 0.0;
  o.max_attempts = 3;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  ASSERT_TRUE(sender.submit(1));
  sender.progress(1, 5ms);  // e.g. a ChunkAck 5 ms after the chunks went out
  const auto s = sender.stats();
  EXPECT_EQ(s.rtt_samples, 1u);
  EXPECT_NEAR(s.rto_ms, 20.0, 1e-6) << "SRTT 5 + max(G 10, 4 x RTTVAR 2.5) -> 15, raised to min_backoff";
  // The id's timeout restarted from that RTO: resent within ~0.5 s, not after the 2 s it started with.
  const auto deadline = Clock::now() + 1500ms;
  while (log.count(1) < 2 && Clock::now() < deadline) std::this_thread::sleep_for(5ms);
  EXPECT_GE(log.count(1), 2u);
  // max_attempts counts sends without any answer: progress after two more keeps the id pending.
  while (log.count(1) < 3 && Clock::now() < deadline + 1s) std::this_thread::sleep_for(2ms);
  sender.progress(1, 5ms);
  std::this_thread::sleep_for(100ms);  // two more timeouts of 20 and 40 ms: sends 4 and 5
  EXPECT_EQ(sender.stats().given_up, 0u) << log.count(1) << " sends";
  EXPECT_GE(log.count(1), 4u);
  sender.progress(99, 5ms);  // an id not pending: a sample, nothing else
  EXPECT_EQ(sender.stats().rtt_samples, 3u);
  ASSERT_TRUE(sender.waitUntilEmpty(3s)) << "given up after 3 sends without an answer";
  EXPECT_EQ(sender.stats().given_up, 1u);
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

/// A network that acknowledges each id `delay` after the send that gets through: every send, or every send
/// but the first of the ids in `lose_first`. A thread of its own calls acknowledge(); it counts the sends.
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
