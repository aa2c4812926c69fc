// udpm:// (LCM multicast on loopback) and dds:// (Cyclone, loopback config) round trips and the DDS
// late joiner and prefix subscriptions. Run only inside tests/transport/run_in_netns.sh (ctest entry
// transport.netns).
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <optional>
#include <thread>

#include "test_tier.hpp"
#include "transport_test_util.hpp"

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;
using testing::Inbox;
using testing::makePayload;

/// Two separate transports (two sockets for LCM, two participants for DDS): small and 300 KB messages.
void roundTrip(const std::string& url) {
  auto tx = testing::makeTestTransport(url);
  auto rx = testing::makeTestTransport(url);
  ASSERT_TRUE(tx && rx);
  Inbox probe, inbox;
  ASSERT_TRUE(rx->subscribe("rgbdmap/robot0/probe", probe.handler()));
  ASSERT_TRUE(rx->subscribe("rgbdmap/robot0/keyframe", inbox.handler()));
  ASSERT_TRUE(rx->start());
  ASSERT_TRUE(testing::waitUntilConnected(*tx, probe, "rgbdmap/robot0/probe"));
  // Also connect the keyframe channel (DDS matches per topic).
  ASSERT_TRUE(testing::waitUntilConnected(*tx, inbox, "rgbdmap/robot0/keyframe"));
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::vector<uint8_t>> sent;
  for (uint32_t i = 0; i < 10; ++i) {
    sent.push_back(makePayload(i % 2 == 0 ? 32 : 300 * 1024, i));
    ASSERT_TRUE(tx->publish("rgbdmap/robot0/keyframe", sent.back()));
  }
  ASSERT_TRUE(inbox.waitForLongerThan(sent.size(), 1, 10s));
  std::printf("[ %s ] 5 x 32 B + 5 x 300 KB received in %.1f ms\n", url.c_str(),
              1e3 * testing::secondsSince(t0));
  EXPECT_EQ(inbox.payloadsLongerThan(1), sent);
  EXPECT_GE(rx->stats().bytes_received, 5u * 300 * 1024);
  EXPECT_EQ(tx->stats().send_errors, 0u);
}

RGBDMAP_TEST_TIER("NetUdpm.*", "elsewhere");  // run in the network namespace (transport.netns)
TEST(NetUdpm, SmallAndLargeRoundTrip) {
  RGBDMAP_REQUIRE_NETNS();
  roundTrip(testing::kUdpmUrl);
}

RGBDMAP_TEST_TIER("NetDds.*", "elsewhere");  // run in the network namespace (transport.netns)
TEST(NetDds, SmallAndLargeRoundTrip) {
  RGBDMAP_REQUIRE_NETNS();
  roundTrip("dds://?domain=0");
}

TEST(NetDds, LateJoinerGetsTheLastMessageOfATransientLocalChannel) {
  RGBDMAP_REQUIRE_NETNS();
  auto tx = testing::makeTestTransport("dds://?domain=0");
  ASSERT_TRUE(tx);
  const auto last = makePayload(300 * 1024, 42);
  ASSERT_TRUE(tx->publish("rgbdmap/server/map", makePayload(1000, 1)));
  ASSERT_TRUE(tx->publish("rgbdmap/server/map", last));
  ASSERT_TRUE(tx->publish("rgbdmap/robot0/keyframe", makePayload(1000, 2)));  // volatile: not kept

  auto late = testing::makeTestTransport("dds://?domain=0");
  ASSERT_TRUE(late);
  Inbox map_inbox, keyframe_inbox;
  ASSERT_TRUE(late->subscribe("rgbdmap/server/map", map_inbox.handler()));
  ASSERT_TRUE(late->subscribe("rgbdmap/robot0/keyframe", keyframe_inbox.handler()));
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(late->start());
  ASSERT_TRUE(map_inbox.waitFor(1, 10s));
  std::printf("[ late joiner ] map received %.1f ms after subscribing\n", 1e3 * testing::secondsSince(t0));
  map_inbox.waitFor(2, 300ms);  // a second (older) sample would be a bug: keep-last 1
  EXPECT_EQ(map_inbox.size(), 1u);
  EXPECT_EQ(map_inbox.messages[0].second, last);
  EXPECT_EQ(keyframe_inbox.size(), 0u);
}

TEST(NetDds, APrefixSubscriptionReadsTheTopicsOthersPublishAsTheyAppear) {
  RGBDMAP_REQUIRE_NETNS();
  auto rx = testing::makeTestTransport("dds://?domain=0");
  auto tx = testing::makeTestTransport("dds://?domain=0");
  ASSERT_TRUE(rx && tx);
  Inbox inbox;
  ASSERT_TRUE(rx->subscribe("rgbdmap/*", inbox.handler()));
  ASSERT_TRUE(rx->start());
  ASSERT_TRUE(rx->publish("rgbdmap/own/hello", makePayload(8, 9)));  // its own topics are not read
  const auto t0 = std::chrono::steady_clock::now();
  // Published before anything matched it: lost (volatile), then read once the reader is there.
  ASSERT_TRUE(testing::waitUntilConnected(*tx, inbox, "rgbdmap/robot_7/keyframe_chunk"));
  std::printf("[ dds prefix ] a new topic read %.1f ms after its first message\n",
              1e3 * testing::secondsSince(t0));
  ASSERT_TRUE(testing::waitUntilConnected(*tx, inbox, "rgbdmap/robot-8/hello"));  // a second one
  ASSERT_TRUE(tx->publish("other/robot_7/keyframe", makePayload(8, 1)));          // outside the prefix
  const auto payload = makePayload(300 * 1024, 3);
  ASSERT_TRUE(tx->publish("rgbdmap/robot_7/keyframe_chunk", payload));
  ASSERT_TRUE(inbox.waitForLongerThan(1, 1, 10s));
  std::map<std::string, int> channels;
  for (const auto& [channel, data] : inbox.messages) ++channels[channel];
  EXPECT_EQ(channels.count("rgbdmap/own/hello"), 0u);
  EXPECT_EQ(channels.count("other/robot_7/keyframe"), 0u);
  EXPECT_GE(channels["rgbdmap/robot-8/hello"], 1);
  EXPECT_EQ(inbox.payloadsLongerThan(1), (std::vector<std::vector<uint8_t>>{payload}));
}

TEST(NetDds, AWriterReportsTheSubscribersMatchedWithIt) {
  RGBDMAP_REQUIRE_NETNS();
  auto tx = testing::makeTestTransport("dds://?domain=0");
  ASSERT_TRUE(tx);
  const std::string channel = "rgbdmap/robot0/keyframe";
  std::optional<SubscriberMatch> match = tx->matchedSubscribers(channel);
  ASSERT_TRUE(match.has_value());
  EXPECT_EQ(match->current, 0);
  EXPECT_EQ(match->total, 0u);
  const auto matched = [&](int current, uint64_t total) {  // polled, at most 10 s
    for (int i = 0; i < 1000; ++i, std::this_thread::sleep_for(10ms))
      if (match = tx->matchedSubscribers(channel); match->current == current && match->total == total)
        return true;
    return false;
  };
  {
    auto rx = testing::makeTestTransport("dds://?domain=0");
    ASSERT_TRUE(rx);
    Inbox inbox;
    ASSERT_TRUE(rx->subscribe(channel, inbox.handler()));
    ASSERT_TRUE(rx->start());
    EXPECT_TRUE(matched(1, 1)) << match->current << " " << match->total;
  }  // the subscriber's participant is deleted: unmatched
  EXPECT_TRUE(matched(0, 1)) << match->current << " " << match->total;
  auto again = testing::makeTestTransport("dds://?domain=0");  // a restarted server: total grows
  Inbox inbox;
  ASSERT_TRUE(again && again->subscribe(channel, inbox.handler()) && again->start());
  EXPECT_TRUE(matched(1, 2)) << match->current << " " << match->total;
}

TEST(NetUdpm, DeliveryDoesNotDependOnAMatch) {
  RGBDMAP_REQUIRE_NETNS();
  auto tx = testing::makeTestTransport("udpm://239.255.76.67:7667?ttl=0");
  ASSERT_TRUE(tx);
  EXPECT_FALSE(tx->matchedSubscribers("rgbdmap/robot0/keyframe").has_value());
}

}  // namespace
}  // namespace rgbdmap::transport
