// ReliableSender's RFC 6298 RTO: the estimator, Karn's rule, a backed-off RTO kept until a valid sample,
// and retransmissions against a slow acker.
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

TEST(TransportReliableSender, RtoFollowsRfc6298) {
  ReliableSenderOptions o;  // initial 100 ms, min 20 ms, max 2 s
  struct Step {
    double sample, srtt, rttvar, rto;
  };
  const Step steps[] = {
      {100, 100, 50, 300},                                     // 2.2: SRTT = R, RTTVAR = R/2
      {200, 112.5, 62.5, 362.5},                               // 2.3: RTTVAR = 3/4 * 50 + 1/4 * |100 - 200|
      {50, 104.6875, 62.5, 354.6875},                          // RTTVAR uses the SRTT before this sample
      {400, 141.6015625, 120.703125, 141.6015625 + 482.8125},  // 4 * RTTVAR
      {1500, 311.4013671875, 430.126953125, 2000},             // 311.4 + 1721.3 above max_backoff
  };
  EXPECT_NEAR(ms(ReliableSender::rto(o, {})), 100.0, 1e-9) << "initial_backoff before any sample";
  RttEstimate e;
  for (const Step& step : steps) {
    e = ReliableSender::updateRtt(e, std::chrono::duration_cast<std::chrono::nanoseconds>(
                                         std::chrono::duration<double, std::milli>(step.sample)));
    EXPECT_NEAR(ms(e.srtt), step.srtt, 1e-5) << step.sample;
    EXPECT_NEAR(ms(e.rttvar), step.rttvar, 1e-5) << step.sample;
    EXPECT_NEAR(ms(ReliableSender::rto(o, e)), step.rto, 1e-5) << step.sample;
  }
  EXPECT_EQ(e.samples, 5u);

  // A steady 100 ms: RTTVAR decays by 3/4 per sample and G keeps the RTO above SRTT.
  RttEstimate steady;
  for (int i = 0; i < 30; ++i) steady = ReliableSender::updateRtt(steady, 100ms);
  EXPECT_NEAR(ms(steady.rttvar), 50.0 * std::pow(0.75, 29), 1e-5);
  EXPECT_NEAR(ms(ReliableSender::rto(o, steady)), 110.0, 1e-5) << "SRTT + G";
  // A fast LAN: SRTT + G = 11 ms, raised to min_backoff.
  RttEstimate fast = ReliableSender::updateRtt({}, 1ms);
  EXPECT_NEAR(ms(ReliableSender::rto(o, fast)), 20.0, 1e-9);
  o.min_backoff = 5ms;
  EXPECT_NEAR(ms(ReliableSender::rto(o, fast)), 11.0, 1e-9);
}

class DelayedAcker {
 public:
  DelayedAcker(std::chrono::milliseconds delay, std::set<uint64_t> lose_first = {})
      : delay_(delay), lose_first_(std::move(lose_first)) {}
  ~DelayedAcker() { stop(); }
  void attach(ReliableSender* sender) {
    sender_ = sender;
    thread_ = std::thread([this] { run(); });
  }
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  ReliableSender::SendFn fn() {
    return [this](uint64_t id) {
      std::lock_guard<std::mutex> lock(mutex_);
      const bool lost = ++sends_[id] == 1 && lose_first_.count(id) != 0;
      if (!lost && answered_.insert(id).second) due_.emplace(Clock::now() + delay_, id);
      wake_.notify_all();
      return Status::success();
    };
  }
  int sends(uint64_t id) {
    std::lock_guard<std::mutex> lock(mutex_);
    return sends_[id];
  }

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stopping_) {
      if (due_.empty()) {
        wake_.wait(lock);
        continue;
      }
      const auto [when, id] = *due_.begin();
      if (Clock::now() < when) {
        wake_.wait_until(lock, when);
        continue;
      }
      due_.erase(due_.begin());
      lock.unlock();
      sender_->acknowledge(id);
      lock.lock();
    }
  }
  std::chrono::milliseconds delay_;
  std::set<uint64_t> lose_first_;
  ReliableSender* sender_ = nullptr;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::set<std::pair<Clock::time_point, uint64_t>> due_;
  std::map<uint64_t, int> sends_;
  std::set<uint64_t>
      answered_;  // ids with an ack scheduled: one ack each, 250 ms after the first send through
  bool stopping_ = false;
  std::thread thread_;
};

/// Submits ids 0..count-1 one after another (the next once the previous is acknowledged).
ReliableSenderStats submitOneAfterAnother(ReliableSenderOptions o, std::chrono::milliseconds ack_delay,
                                          int count) {
  DelayedAcker network(ack_delay);
  ReliableSender sender(o, network.fn());
  network.attach(&sender);
  sender.start();
  for (int id = 0; id < count; ++id) {
    EXPECT_TRUE(sender.submit(static_cast<uint64_t>(id)));
    EXPECT_TRUE(sender.waitUntilEmpty(5s)) << id;
  }
  sender.stop();
  network.stop();
  return sender.stats();
}

/// A server that acknowledges after 250 ms. The fixed 100 ms schedule resends (nearly) every id;
/// the adaptive RTO resends the first ids only, until a send is answered before its timeout (Karn).
TEST(TransportReliableSender, AdaptiveRtoStopsResendingToASlowAcker) {
  ReliableSenderOptions o;
  o.max_attempts = 1000;
  o.adaptive = false;
  const ReliableSenderStats fixed = submitOneAfterAnother(o, 250ms, 20);
  EXPECT_GE(fixed.retransmissions, 15u) << "each id resent after ~100 ms";
  EXPECT_EQ(fixed.acked, 20u);
  o.adaptive = true;
  const ReliableSenderStats adaptive = submitOneAfterAnother(o, 250ms, 20);
  std::printf(
      "[ rto ] ack after 250 ms, 20 ids: %llu retransmissions fixed, %llu adaptive (SRTT %.1f ms, "
      "RTTVAR %.1f ms, RTO %.1f ms, %llu samples)\n",
      static_cast<unsigned long long>(fixed.retransmissions),
      static_cast<unsigned long long>(adaptive.retransmissions), adaptive.srtt_ms, adaptive.rttvar_ms,
      adaptive.rto_ms, static_cast<unsigned long long>(adaptive.rtt_samples));
  EXPECT_EQ(adaptive.acked, 20u);
  EXPECT_LE(adaptive.retransmissions, 5u);
  EXPECT_GE(adaptive.srtt_ms, 200.0);
  EXPECT_LE(adaptive.srtt_ms, 600.0);
  EXPECT_GE(adaptive.rto_ms, adaptive.srtt_ms);
  EXPECT_GE(adaptive.rtt_samples, 15u);
}

TEST(TransportReliableSender, KarnsRuleRetransmittedIdsGiveNoSample) {
  ReliableSenderOptions o;
  o.initial_backoff = 500ms;  // far above the 20 ms acks: a single send is never resent on a loaded machine
  o.min_backoff = 500ms;
  o.jitter = 0.0;
  DelayedAcker network(20ms, {2, 3});  // ids 2 and 3: first send lost, acknowledged after the retransmission
  ReliableSender sender(o, network.fn());
  network.attach(&sender);
  sender.start();
  auto roundTrip = [&](uint64_t id) {
    ASSERT_TRUE(sender.submit(id));
    ASSERT_TRUE(sender.waitUntilEmpty(5s)) << id;
  };
  roundTrip(1);
  EXPECT_EQ(sender.stats().rtt_samples, 1u);
  roundTrip(2);
  roundTrip(3);
  EXPECT_EQ(network.sends(2), 2);
  EXPECT_EQ(network.sends(3), 2);
  const ReliableSenderStats s = sender.stats();
  EXPECT_EQ(s.rtt_samples, 1u) << "an ack after a retransmission is ambiguous";
  EXPECT_EQ(s.retransmissions, 2u);
  EXPECT_LT(s.srtt_ms, 400.0) << "the ~520 ms acks of ids 2 and 3 did not enter the estimate";
  roundTrip(4);
  EXPECT_EQ(sender.stats().rtt_samples, 2u);
}

/// RFC 6298 5.5-5.7: without acks the RTO backs off and new ids start from it; the acks of retransmitted ids
/// leave it there; the next valid sample brings it back to SRTT + max(G, 4 RTTVAR).
TEST(TransportReliableSender, BackedOffRtoIsKeptUntilAValidSample) {
  ReliableSenderOptions o;
  o.initial_backoff = 50ms;
  o.max_backoff = 800ms;
  o.jitter = 0.0;
  o.max_attempts = 1000;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  ASSERT_TRUE(sender.submit(1));  // never answered: sends at 0, 50, 150, 350 ms (timeouts 50, 100, 200, 400)
  const auto deadline = Clock::now() + 5s;
  while (log.count(1) < 4 && Clock::now() < deadline) std::this_thread::sleep_for(10ms);
  ASSERT_GE(log.count(1), 4u);
  const double backed_off = sender.stats().rto_ms;
  EXPECT_GE(backed_off, 400.0);
  EXPECT_EQ(sender.stats().rtt_samples, 0u);
  ASSERT_TRUE(sender.submit(2));  // starts from the backed-off RTO, not from 50 ms
  while (log.count(2) < 2 && Clock::now() < deadline) std::this_thread::sleep_for(10ms);
  ASSERT_EQ(log.count(2), 2u);
  {
    std::lock_guard<std::mutex> lock(log.mutex);
    EXPECT_GE(ms(log.sends[2][1] - log.sends[2][0]), backed_off - 1.0);
  }
  EXPECT_TRUE(sender.acknowledge(1));
  EXPECT_TRUE(sender.acknowledge(2));
  ReliableSenderStats s = sender.stats();
  EXPECT_EQ(s.rtt_samples, 0u) << "Karn: both were retransmitted";
  EXPECT_GE(s.rto_ms, backed_off) << "still backed off";
  ASSERT_TRUE(sender.submit(3));
  EXPECT_TRUE(sender.acknowledge(3));  // at once: a valid sample of ~0 ms
  s = sender.stats();
  EXPECT_EQ(s.rtt_samples, 1u);
  EXPECT_LT(s.rto_ms, 100.0);
  EXPECT_NEAR(s.rto_ms, std::max(20.0, s.srtt_ms + std::max(10.0, 4.0 * s.rttvar_ms)), 1e-6);
}

/// shared_backoff = false: an id that is never answered backs off on its own; a new id starts from the RTO
/// of the samples, not from that backoff.
TEST(TransportReliableSender, UnsharedBackoffLeavesTheRtoOfNewIdsAlone) {
  ReliableSenderOptions o;
  o.initial_backoff = 50ms;
  o.max_backoff = 800ms;
  o.jitter = 0.0;
  o.max_attempts = 1000;
  o.shared_backoff = false;
  SendLog log;
  ReliableSender sender(o, log.fn());
  sender.start();
  ASSERT_TRUE(sender.submit(1));  // never answered: timeouts 50, 100, 200, 400 ms
  const auto deadline = Clock::now() + 5s;
  while (log.count(1) < 4 && Clock::now() < deadline) std::this_thread::sleep_for(10ms);
  ASSERT_GE(log.count(1), 4u);
  EXPECT_NEAR(sender.stats().rto_ms, 50.0, 1e-6) << "no sample yet: initial_backoff";
  ASSERT_TRUE(sender.submit(2));
  while (log.count(2) < 2 && Clock::now() < deadline) std::this_thread::sleep_for(10ms);
  ASSERT_EQ(log.count(2), 2u);
  {
    std::lock_guard<std::mutex> lock(log.mutex);
    EXPECT_LT(ms(log.sends[2][1] - log.sends[2][0]), 300.0) << "its own first timeout: 50 ms";
    const auto& ones = log.sends[1];
    EXPECT_GE(ms(ones[3] - ones[2]), 200.0 - 1.0) << "id 1 still backs off";
  }
  EXPECT_TRUE(sender.acknowledge(1));
  EXPECT_TRUE(sender.acknowledge(2));
}

}  // namespace
}  // namespace rgbdmap::transport
