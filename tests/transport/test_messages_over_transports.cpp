// Every message type, sealed and signed as in production (proto/), travels over every transport on its
// own channel and opens on the far side: memq in-process; udpm and DDS inside the loopback-only network
// namespace (ctest entry transport.netns). Includes a 300 KB keyframe.
#include <set>

#include <gtest/gtest.h>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/transport/republisher.hpp"
#include "test_tier.hpp"
#include "transport/transport_test_util.hpp"

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;
using msg::Bytes;

struct Sealed {
  std::string channel;
  Bytes bytes;
};

std::vector<Sealed> sealEverything() {
  msg::Signer robot("robot_1", rgbdmap::testing::testKey(1), 5);
  msg::Signer server(msg::kServerId, rgbdmap::testing::testKey(1), 6);
  std::vector<Bytes> envelopes = rgbdmap::testing::sampleEnvelopes(&robot, &server);
  envelopes.push_back(robot.seal(rgbdmap::testing::sampleKeyframe(1000, 640, 480, 96), 2).value());
  EXPECT_GE(envelopes.back().size(), 300000u);
  std::vector<Sealed> out;
  for (const Bytes& e : envelopes) {
    msg::KeyStore keys = msg::KeyStore::openMode();  // only to learn the type for the channel name
    const auto opened = msg::openEnvelope(e, keys, nullptr);
    EXPECT_TRUE(opened) << opened.error();
    out.push_back({msg::channelFor(opened->type, "robot_1").value(), e});
  }
  return out;
}

// Publishes everything from tx, receives on rx, and opens each received envelope with the real keys.
void sendAll(Transport& tx, Transport& rx) {
  const std::vector<Sealed> sealed = sealEverything();
  testing::Inbox inbox;
  std::set<std::string> channels;
  for (const auto& s : sealed) {
    if (channels.insert(s.channel).second) {
      ASSERT_TRUE(rx.subscribe(s.channel, inbox.handler()));
    }
  }
  ASSERT_TRUE(rx.start());
  for (const auto& c : channels) ASSERT_TRUE(testing::waitUntilConnected(tx, inbox, c)) << c;
  for (const auto& s : sealed) ASSERT_TRUE(tx.publish(s.channel, s.bytes)) << s.channel;
  ASSERT_TRUE(inbox.waitForLongerThan(sealed.size(), 1, 10s));
  msg::KeyStore keys;
  ASSERT_TRUE(keys.add("robot_1", rgbdmap::testing::testKey(1)));
  ASSERT_TRUE(keys.add(msg::kServerId, rgbdmap::testing::testKey(1)));
  msg::ReplayGuard guard;
  std::multiset<msg::MessageType> types;
  for (const auto& payload : inbox.payloadsLongerThan(1)) {
    const auto opened = msg::openEnvelope(payload, keys, &guard);
    ASSERT_TRUE(opened) << opened.error();
    EXPECT_TRUE(opened->authenticated);
    types.insert(opened->type);
  }
  EXPECT_EQ(types.size(), sealed.size());
  for (int t = 1; t <= 9; ++t) EXPECT_GE(types.count(static_cast<msg::MessageType>(t)), 1u) << "type " << t;
  rx.stop();
}

TEST(MessagesOverTransports, EveryMessageOverMemq) {
  auto t = testing::makeTestTransport("memq://");
  ASSERT_TRUE(t);
  sendAll(*t, *t);
}

RGBDMAP_TEST_TIER("NetMessagesOverTransports.*",
                  "elsewhere");  // run in the network namespace (transport.netns)
TEST(NetMessagesOverTransports, EveryMessageOverUdpm) {
  RGBDMAP_REQUIRE_NETNS();
  auto tx = testing::makeTestTransport(testing::kUdpmUrl), rx = testing::makeTestTransport(testing::kUdpmUrl);
  ASSERT_TRUE(tx && rx);
  sendAll(*tx, *rx);
}

TEST(NetMessagesOverTransports, EveryMessageOverDds) {
  RGBDMAP_REQUIRE_NETNS();
  auto tx = testing::makeTestTransport("dds://?domain=0"), rx = testing::makeTestTransport("dds://?domain=0");
  ASSERT_TRUE(tx && rx);
  sendAll(*tx, *rx);
}

TEST(LatestRepublisher, LateSubscriberGetsTheLatestMapOverLcm) {
  auto t = testing::makeTestTransport("memq://");
  ASSERT_TRUE(t);
  testing::Inbox marker;  // memq dispatches in order: once the marker is in, the earlier messages were too
  ASSERT_TRUE(t->subscribe("rgbdmap/test/marker", marker.handler()));
  ASSERT_TRUE(t->start());
  RepublisherOptions options;
  options.period = 20ms;
  LatestRepublisher republisher(*t, options);
  republisher.start();
  ASSERT_TRUE(republisher.publish("rgbdmap/server/map", testing::makePayload(1000, 1)));
  ASSERT_TRUE(republisher.publish("rgbdmap/server/map", testing::makePayload(1000, 2)));
  ASSERT_TRUE(republisher.publish("rgbdmap/robot_1/keyframe", testing::makePayload(1000, 3)));
  ASSERT_TRUE(t->publish("rgbdmap/test/marker", testing::makePayload(10, 4)));
  ASSERT_TRUE(marker.waitFor(1, 5s));
  testing::Inbox late, keyframes;  // subscribed after everything was published
  ASSERT_TRUE(t->subscribe("rgbdmap/server/map", late.handler()));
  ASSERT_TRUE(t->subscribe("rgbdmap/robot_1/keyframe", keyframes.handler()));
  ASSERT_TRUE(late.waitFor(2, 5s));
  for (const auto& p : late.payloadsLongerThan(0))
    EXPECT_EQ(p, testing::makePayload(1000, 2)) << "latest only";
  republisher.stop();
  EXPECT_EQ(keyframes.size(), 0u) << "keyframes are not latest-for-late-joiners: never re-sent";
  EXPECT_GE(republisher.republished(), 2u);
  t->stop();
}

TEST(LatestRepublisher, StopIsPrompt) {
  auto t = testing::makeTestTransport("memq://");
  ASSERT_TRUE(t);
  RepublisherOptions options;
  options.period = std::chrono::hours(1);
  LatestRepublisher republisher(*t, options);
  republisher.start();
  const auto t0 = std::chrono::steady_clock::now();
  republisher.stop();
  EXPECT_LT(testing::secondsSince(t0), 2.0);  // woken by the condition variable, not the hour-long period
  republisher.stop();                         // idempotent
}

}  // namespace
}  // namespace rgbdmap::transport

namespace rgbdmap::transport {
namespace {

TEST(LatestRepublisher, RefreshReSealsEachRepublishSoReplayProtectionAcceptsIt) {
  // The server's map is re-sealed (fresh seq) at every re-publish; a receiver with a replay guard accepts
  // each copy. Re-sending the very same bytes would be refused as a replay.
  msg::Signer server(msg::kServerId, rgbdmap::testing::testKey(1), 9);
  msg::KeyStore keys;
  ASSERT_TRUE(keys.add(msg::kServerId, rgbdmap::testing::testKey(1)));
  msg::ReplayGuard guard;
  const std::string channel = msg::channelFor(msg::MessageType::kMapUpdate, "robot_1").value();
  auto t = makeTransport("memq://");
  ASSERT_TRUE(t.ok());
  testing::Inbox inbox;
  ASSERT_TRUE((*t)->subscribe(channel, inbox.handler()));
  ASSERT_TRUE((*t)->start());
  RepublisherOptions options;
  options.period = std::chrono::milliseconds(10);
  options.refresh = [&](const std::string&, const std::vector<uint8_t>&) {
    return server.seal(rgbdmap::testing::sampleMap(), 1).value();
  };
  LatestRepublisher republisher(**t, options);
  republisher.start();
  ASSERT_TRUE(republisher.publish(channel, server.seal(rgbdmap::testing::sampleMap(), 0).value()));
  ASSERT_TRUE(inbox.waitFor(4, std::chrono::seconds(5)));
  republisher.stop();
  (*t)->stop();
  for (const auto& bytes : inbox.payloadsLongerThan(0)) {
    const auto opened = msg::openEnvelope(bytes, keys, &guard);
    EXPECT_TRUE(opened) << opened.error();
  }
  // The first copy again: a replay.
  EXPECT_FALSE(msg::openEnvelope(inbox.payloadsLongerThan(0).front(), keys, &guard));
}

TEST(ReplayGuardStreams, LateJoinerAcceptsAnOldMapAfterManyNewerStatusMessages) {
  msg::Signer server(msg::kServerId, rgbdmap::testing::testKey(1), 9);
  msg::KeyStore keys;
  ASSERT_TRUE(keys.add(msg::kServerId, rgbdmap::testing::testKey(1)));
  const auto map = server.seal(rgbdmap::testing::sampleMap(), 0).value();  // seq 0
  std::vector<msg::Bytes> status;
  for (int i = 0; i < 100; ++i) status.push_back(server.seal(rgbdmap::testing::sampleStatus(), i).value());
  msg::ReplayGuard guard;  // a robot that joins late: the newest status first, then the durable map
  ASSERT_TRUE(msg::openEnvelope(status.back(), keys, &guard));
  EXPECT_TRUE(msg::openEnvelope(map, keys, &guard)) << "windows are per message type";
  EXPECT_FALSE(msg::openEnvelope(map, keys, &guard)) << "but a duplicate is still a replay";
}

}  // namespace
}  // namespace rgbdmap::transport
