// Channel-name rules and the transport factory.
#include <gtest/gtest.h>

#include <cstdlib>

#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::transport {
namespace {

TEST(TransportChannel, DdsTopicNamesAreValidAndOneToOne) {
  EXPECT_EQ(ddsTopicName("rgbdmap/robot1/keyframe"), "rgbdmap__robot1__keyframe");
  EXPECT_EQ(ddsTopicName("a_b"), "a_x5Fb");
  EXPECT_EQ(ddsTopicName("3d.map"), "_x33d_x2Emap");
  EXPECT_NE(ddsTopicName("a/b"), ddsTopicName("a_b"));
  EXPECT_NE(ddsTopicName("a__b"), ddsTopicName("a//b"));
  for (char c : ddsTopicName("rgbdmap/robot-7/pose graph!")) {
    EXPECT_TRUE(std::isalnum(static_cast<unsigned char>(c)) || c == '_') << c;
  }
}

TEST(TransportChannel, DdsTopicNamesReadBackAsTheirChannelsAndNothingElse) {
  for (const std::string channel :
       {"rgbdmap/robot1/keyframe_chunk", "rgbdmap/robot-7/pose graph!", "3d.map", "a__b"}) {
    std::string back;
    ASSERT_TRUE(channelFromDdsTopic(ddsTopicName(channel), &back)) << channel;
    EXPECT_EQ(back, channel);
  }
  std::string out = "unchanged";
  for (const std::string topic : {"rt/map", "a_b", "a_x5", "a_xZZ", "a_x41", "_", "9lives", "caf\xc3\xa9"})
    EXPECT_FALSE(channelFromDdsTopic(topic, &out)) << topic;  // "a_x41" would be "aA": not how it is named
  EXPECT_EQ(out, "unchanged");
}

TEST(TransportChannel, LateJoinerChannels) {
  TransportOptions options;
  EXPECT_TRUE(isLatestForLateJoiners("rgbdmap/server/map", options));
  EXPECT_TRUE(isLatestForLateJoiners("rgbdmap/server/slice", options));
  EXPECT_TRUE(isLatestForLateJoiners("rgbdmap/robot1/status", options));
  EXPECT_TRUE(isLatestForLateJoiners("rgbdmap/robot1/loops", options));  // loop edges reach a late viewer
  EXPECT_FALSE(isLatestForLateJoiners("rgbdmap/robot1/pose", options));  // the live pose: volatile
  EXPECT_FALSE(isLatestForLateJoiners("rgbdmap/robot1/keyframe", options));
  EXPECT_FALSE(isLatestForLateJoiners("rgbdmap/robot1/mapx", options));
  options.latest_for_late_joiners_channels = {"rgbdmap/server/graph"};
  EXPECT_TRUE(isLatestForLateJoiners("rgbdmap/server/graph", options));
}

TEST(TransportChannel, PrefixMatching) {
  EXPECT_TRUE(channelMatches("rgbdmap/robot1/keyframe", "rgbdmap/robot1/keyframe"));
  EXPECT_FALSE(channelMatches("rgbdmap/robot1/keyframe", "rgbdmap/robot1/keyframes"));
  EXPECT_TRUE(channelMatches("rgbdmap/robot1/*", "rgbdmap/robot1/pose"));
  EXPECT_FALSE(channelMatches("rgbdmap/robot1/*", "rgbdmap/robot2/pose"));
  EXPECT_FALSE(channelMatches("rgbdmap/robot1/*", "rgbdmap/robot1"));
  EXPECT_TRUE(channelMatches("*", "anything"));
}

TEST(TransportFactory, RejectsUnknownAndBadUrls) {
  EXPECT_FALSE(makeTransport("tcp://localhost:1234").ok());
  EXPECT_FALSE(makeTransport("dds://?domain=abc").ok());
  EXPECT_FALSE(makeTransport("dds://?domain=999").ok());
  auto memq = makeTransport("memq://");
  ASSERT_TRUE(memq.ok()) << memq.error();
}

TEST(TransportFactory, DdsRefusesToRunWithoutAnExplicitConfig) {
  const char* old = std::getenv("CYCLONEDDS_URI");
  const std::string saved = old != nullptr ? old : "";
  unsetenv("CYCLONEDDS_URI");
  auto dds = makeTransport("dds://?domain=0");
  EXPECT_FALSE(dds.ok());
  EXPECT_NE(dds.error().find("CYCLONEDDS_URI"), std::string::npos);
  if (old != nullptr) setenv("CYCLONEDDS_URI", saved.c_str(), 1);
}

}  // namespace
}  // namespace rgbdmap::transport
