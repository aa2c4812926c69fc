// Fault injection (drop=, drop_rx=, drop_seed= on any transport URL): the parameters are validated and
// stripped before the adapter sees the URL, about the requested share of whole messages is dropped on
// publish and on receive, the drops are counted in TransportStats, and a seed gives the same drops again.
#include <gtest/gtest.h>

#include <chrono>
#include <cstring>
#include <set>
#include <thread>

#include "transport_test_util.hpp"

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;
using testing::Inbox;

constexpr char kChannel[] = "rgbdmap/robot0/keyframe";
constexpr uint32_t kMessages = 1000;

std::unique_ptr<Transport> make(const std::string& url) {
  auto t = makeTransport(url);
  EXPECT_TRUE(t.ok()) << t.error();
  return t.ok() ? std::move(t).value() : nullptr;
}

/// Publishes kMessages numbered messages through `t` and returns the numbers its subscriber received.
std::set<uint32_t> roundTrip(Transport& t) {
  Inbox inbox;
  EXPECT_TRUE(t.subscribe(kChannel, inbox.handler()));
  EXPECT_TRUE(t.start());
  for (uint32_t i = 0; i < kMessages; ++i) {
    uint8_t bytes[4];
    std::memcpy(bytes, &i, sizeof i);
    EXPECT_TRUE(t.publish(kChannel, bytes, sizeof bytes));  // a dropped message still "succeeds"
    if (i % 100 == 99) std::this_thread::sleep_for(5ms);    // keeps LCM's receive queue short
  }
  // Every message published reaches the adapter's receive side; those not dropped there reach the inbox.
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  TransportStats s = t.stats();
  while ((s.received < s.sent || inbox.size() < s.received - s.fault_dropped_received) &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(2ms);
    s = t.stats();
  }
  std::set<uint32_t> got;
  std::lock_guard<std::mutex> lock(inbox.mutex);
  for (const auto& m : inbox.messages) {
    uint32_t i = 0;
    std::memcpy(&i, m.second.data(), sizeof i);
    got.insert(i);
  }
  return got;
}

TEST(TransportFaults, BadParametersAreRefused) {
  for (const char* url : {"memq://?drop=1", "memq://?drop=-0.1", "memq://?drop=x", "memq://?drop_rx=2",
                          "memq://?drop=0.1&drop_seed=-3", "dds://?domain=0&drop="})
    EXPECT_FALSE(makeTransport(url).ok()) << url;
}

TEST(TransportFaults, ZeroDropIsThePlainAdapter) {
  auto t = make("memq://?drop=0&drop_seed=3");
  ASSERT_TRUE(t);
  EXPECT_EQ(roundTrip(*t).size(), kMessages);
  EXPECT_EQ(t->stats().fault_dropped_published, 0u);
}

TEST(TransportFaults, DropsAboutTheShareAskedOnPublishAndCountsThem) {
  auto t = make("memq://?drop=0.3&drop_seed=7");
  ASSERT_TRUE(t);
  const std::set<uint32_t> got = roundTrip(*t);
  const TransportStats s = t->stats();
  EXPECT_EQ(got.size() + s.fault_dropped_published, kMessages);
  EXPECT_EQ(s.sent, got.size());
  EXPECT_EQ(s.fault_dropped_received, 0u);
  EXPECT_NEAR(static_cast<double>(s.fault_dropped_published), 0.3 * kMessages, 75.0);  // ~5 sigma
}

TEST(TransportFaults, DropsOnReceiveAndCountsThem) {
  auto t = make("memq://?drop_rx=0.6&drop_seed=9");
  ASSERT_TRUE(t);
  const std::set<uint32_t> got = roundTrip(*t);
  const TransportStats s = t->stats();
  EXPECT_EQ(s.sent, kMessages);
  EXPECT_EQ(s.fault_dropped_published, 0u);
  EXPECT_EQ(got.size() + s.fault_dropped_received, kMessages);
  EXPECT_NEAR(static_cast<double>(s.fault_dropped_received), 0.6 * kMessages, 80.0);
}

TEST(TransportFaults, TheSeedGivesTheSameDrops) {
  auto a = make("memq://?drop=0.5&drop_seed=11");
  auto b = make("memq://?drop_seed=11&drop=0.5");
  auto c = make("memq://?drop=0.5&drop_seed=12");
  ASSERT_TRUE(a && b && c);
  const std::set<uint32_t> got_a = roundTrip(*a);
  EXPECT_EQ(got_a, roundTrip(*b));
  EXPECT_NE(got_a, roundTrip(*c));
}

}  // namespace
}  // namespace rgbdmap::transport
