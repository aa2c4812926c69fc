// Reliable delivery over lossy LCM: the receiver drops ~30% of keyframes and ~20% of its acks (seeded);
// ReliableSender + acks + DedupFilter must deliver every one of 200 keyframe-sized messages exactly once.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <random>

#include "rgbdmap/transport/reliable.hpp"
#include "test_tier.hpp"
#include "transport_test_util.hpp"

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;

constexpr char kData[] = "rgbdmap/robot3/keyframe";
constexpr char kAck[] = "rgbdmap/robot3/keyframe_ack";
constexpr uint64_t kSender = 3;

uint64_t readU64(const uint8_t* p) {
  uint64_t v = 0;
  std::memcpy(&v, p, sizeof(v));
  return v;
}

/// Receiver side: seeded drops, acks, dedup, exactly-once bookkeeping.
struct LossyReceiver {
  std::mt19937 rng{12345};
  std::bernoulli_distribution drop_data{0.30}, drop_ack{0.20};
  DedupFilter dedup;
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<int> delivered;
  uint64_t dropped = 0, corrupt = 0;

  void onData(Transport& t, const uint8_t* d, size_t n) {
    if (n < 16 || drop_data(rng)) {
      ++dropped;
      return;
    }
    const uint64_t sender = readU64(d), id = readU64(d + 8);
    if (!drop_ack(rng)) t.publish(kAck, d + 8, 8);
    if (!dedup.accept(sender, id)) return;
    std::lock_guard<std::mutex> lock(mutex);
    if (id >= delivered.size() ||
        testing::makePayload(n - 16, static_cast<uint32_t>(id)) != std::vector<uint8_t>(d + 16, d + n)) {
      ++corrupt;
      return;
    }
    ++delivered[id];
    cv.notify_all();
  }
};

void runLossTest(Transport& tx, Transport& rx, size_t count, size_t size) {
  std::vector<std::vector<uint8_t>> frames(count);
  for (size_t id = 0; id < count; ++id) {
    auto& f = frames[id];
    f.resize(16);
    std::memcpy(f.data(), &kSender, 8);
    std::memcpy(f.data() + 8, &id, 8);
    const auto payload = testing::makePayload(size, static_cast<uint32_t>(id));
    f.insert(f.end(), payload.begin(), payload.end());
  }
  ReliableSenderOptions o;
  o.max_pending = 32;
  o.initial_backoff = 30ms;
  o.max_backoff = 300ms;
  o.max_attempts = 60;
  ReliableSender sender(o, [&](uint64_t id) { return tx.publish(kData, frames[id]); });
  LossyReceiver receiver;
  receiver.delivered.assign(count, 0);
  ASSERT_TRUE(tx.subscribe(kAck, [&](const std::string&, const uint8_t* d, size_t n) {
    if (n == 8) sender.acknowledge(readU64(d));
  }));
  ASSERT_TRUE(rx.subscribe(
      kData, [&](const std::string&, const uint8_t* d, size_t n) { receiver.onData(rx, d, n); }));
  ASSERT_TRUE(tx.start());
  ASSERT_TRUE(rx.start());
  sender.start();
  const auto t0 = std::chrono::steady_clock::now();
  for (uint64_t id = 0; id < count; ++id) {
    ASSERT_TRUE(sender.waitForCapacity(10s)) << id;
    ASSERT_TRUE(sender.submit(id)) << id;
  }
  ASSERT_TRUE(sender.waitUntilEmpty(30s));
  const double seconds = testing::secondsSince(t0);
  sender.stop();
  rx.stop();
  tx.stop();
  const auto s = sender.stats();
  std::printf(
      "[ loss ] %zu x %zu B in %.2f s: %llu retransmissions, %llu dropped by the receiver, "
      "%llu duplicates filtered\n",
      count, size, seconds, static_cast<unsigned long long>(s.retransmissions),
      static_cast<unsigned long long>(receiver.dropped),
      static_cast<unsigned long long>(receiver.dedup.duplicates()));
  EXPECT_EQ(s.acked, count);
  EXPECT_EQ(s.given_up, 0u);
  EXPECT_GT(s.retransmissions, count / 5);
  EXPECT_GT(receiver.dedup.duplicates(), 0u);  // lost acks cause re-deliveries that are filtered
  EXPECT_EQ(receiver.corrupt, 0u);
  for (size_t id = 0; id < count; ++id) EXPECT_EQ(receiver.delivered[id], 1) << id;
  EXPECT_LT(seconds, 30.0);
}

TEST(TransportLoss, MemqEveryKeyframeArrivesExactlyOnce) {
  auto t = makeTransport("memq://");
  ASSERT_TRUE(t.ok()) << t.error();
  runLossTest(**t, **t, 200, 110 * 1024);
}

RGBDMAP_TEST_TIER("NetLoss.*", "elsewhere");  // run in the network namespace (transport.netns)
TEST(NetLoss, UdpmEveryKeyframeArrivesExactlyOnce) {
  RGBDMAP_REQUIRE_NETNS();
  auto tx = makeTransport(testing::kUdpmUrl);
  auto rx = makeTransport(testing::kUdpmUrl);
  ASSERT_TRUE(tx.ok() && rx.ok());
  runLossTest(**tx, **rx, 200, 110 * 1024);
}

}  // namespace
}  // namespace rgbdmap::transport
