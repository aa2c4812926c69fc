// LCM memq:// (in-process) round trips: small and 300 KB payloads, many channels, prefixes, stats, stop.
#include <gtest/gtest.h>

#include <chrono>
#include <set>

#include "transport_test_util.hpp"

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;
using testing::Inbox;
using testing::makePayload;

std::unique_ptr<Transport> makeMemq() {
  auto t = makeTransport("memq://");
  EXPECT_TRUE(t.ok()) << t.error();
  return std::move(t).value();
}

TEST(TransportMemq, SmallAndLargeRoundTrip) {
  auto t = makeMemq();
  Inbox inbox;
  ASSERT_TRUE(t->subscribe("rgbdmap/robot0/keyframe", inbox.handler()));
  ASSERT_TRUE(t->start());
  const auto small = makePayload(16, 1);
  const auto large = makePayload(300 * 1024, 2);
  ASSERT_TRUE(t->publish("rgbdmap/robot0/keyframe", small));
  ASSERT_TRUE(t->publish("rgbdmap/robot0/keyframe", large));
  ASSERT_TRUE(inbox.waitFor(2, 5s));
  EXPECT_EQ(inbox.messages[0].second, small);
  EXPECT_EQ(inbox.messages[1].second, large);
  const TransportStats s = t->stats();
  EXPECT_EQ(s.sent, 2u);
  EXPECT_EQ(s.received, 2u);
  EXPECT_EQ(s.bytes_sent, small.size() + large.size());
  EXPECT_EQ(s.bytes_received, s.bytes_sent);
  EXPECT_EQ(s.send_errors, 0u);
}

TEST(TransportMemq, ManyChannelsReachOnlyTheirSubscribers) {
  auto t = makeMemq();
  constexpr int kChannels = 50;
  std::vector<Inbox> inboxes(kChannels);
  for (int c = 0; c < kChannels; ++c) {
    ASSERT_TRUE(t->subscribe("rgbdmap/robot" + std::to_string(c) + "/pose", inboxes[c].handler()));
  }
  Inbox prefix;
  ASSERT_TRUE(t->subscribe("rgbdmap/robot1*", prefix.handler()));  // robot1, robot10..robot19
  ASSERT_TRUE(t->start());
  ASSERT_TRUE(t->publish("rgbdmap/nobody/listens", makePayload(8, 0)));
  for (int round = 0; round < 4; ++round) {
    for (int c = 0; c < kChannels; ++c) {
      const auto payload = makePayload(64, static_cast<uint32_t>(c * 10 + round));
      ASSERT_TRUE(t->publish("rgbdmap/robot" + std::to_string(c) + "/pose", payload));
    }
  }
  for (int c = 0; c < kChannels; ++c) {
    ASSERT_TRUE(inboxes[c].waitFor(4, 5s)) << c;
    for (const auto& [channel, bytes] : inboxes[c].messages) {
      EXPECT_EQ(channel, "rgbdmap/robot" + std::to_string(c) + "/pose");
    }
    EXPECT_EQ(inboxes[c].messages[3].second, makePayload(64, static_cast<uint32_t>(c * 10 + 3)));
  }
  ASSERT_TRUE(prefix.waitFor(44, 5s));
  t->stop();
  EXPECT_EQ(prefix.size(), 44u);  // 11 channels x 4 rounds
  EXPECT_EQ(t->stats().received, kChannels * 4u + 1u);
  EXPECT_EQ(t->stats().dropped, 1u);  // the channel nobody subscribed to
}

TEST(TransportMemq, HandlerMayPublishAndStopIsPromptAndRepeatable) {
  auto t = makeMemq();
  Inbox replies;
  ASSERT_TRUE(t->subscribe(
      "req", [&](const std::string&, const uint8_t* d, size_t n) { EXPECT_TRUE(t->publish("rep", d, n)); }));
  ASSERT_TRUE(t->subscribe("rep", replies.handler()));
  for (int run = 0; run < 3; ++run) {
    ASSERT_TRUE(t->start());
    ASSERT_TRUE(t->publish("req", makePayload(100, static_cast<uint32_t>(run))));
    ASSERT_TRUE(replies.waitFor(static_cast<size_t>(run + 1), 5s));
    const auto t0 = std::chrono::steady_clock::now();
    t->stop();
    EXPECT_LT(testing::secondsSince(t0), 2.0);  // woken by its eventfd, not by a timeout
  }
  t->stop();  // idempotent
}

}  // namespace
}  // namespace rgbdmap::transport
