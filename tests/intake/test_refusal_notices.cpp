// The server's unsigned answer to a robot it does not serve: when it is sent, what it says, and the bounds
// that keep invented robot ids from flooding the network or growing the table (the inbox sending it:
// test_inbox.cpp; the robot reading it: tests/link/test_robot_link_server_messages.cpp).
#include <chrono>
#include <string>

#include <gtest/gtest.h>

#include "rgbdmap/intake/refusal_notices.hpp"

namespace rgbdmap {
namespace {

using Clock = RefusalNotices::Clock;
using std::chrono::milliseconds;
using std::chrono::seconds;

TEST(RefusalNotices, AnswersTheFirstRefusalAtOnceThenAtMostOncePerInterval) {
  RefusalNotices notices;
  const Clock::time_point t0 = Clock::now();
  const auto first = notices.refused("robot2", "unknown_robot", t0);
  ASSERT_TRUE(first);
  EXPECT_EQ(first->state, "not serving robot2");
  EXPECT_TRUE(first->robots.empty());
  ASSERT_EQ(first->rejects.size(), 1u);
  EXPECT_EQ(first->rejects[0].robot_id, "robot2");
  EXPECT_EQ(first->rejects[0].reason, "unknown_robot");
  EXPECT_EQ(first->rejects[0].count, 1);
  EXPECT_FALSE(notices.refused("robot2", "unknown_robot", t0 + milliseconds(500)));
  EXPECT_FALSE(notices.refused("robot2", "unknown_robot", t0 + milliseconds(900)));
  const auto second = notices.refused("robot2", "unknown_robot", t0 + milliseconds(1100));
  ASSERT_TRUE(second);
  EXPECT_EQ(second->rejects[0].count, 4) << "every refused message is counted, noticed or not";
  EXPECT_TRUE(notices.refused("robot3", "unknown_sender", t0 + milliseconds(1100))) << "per id";
  EXPECT_EQ(notices.sent(), 3u);
}

TEST(RefusalNotices, InventedIdsCannotFloodTheNetworkNorGrowTheTable) {
  RefusalNoticeOptions options;
  options.per_second = 8.0;
  options.max_ids = 16;
  options.forget_after_s = 60.0;
  RefusalNotices notices(options);
  const Clock::time_point t0 = Clock::now();
  int answered = 0;
  for (int i = 0; i < 1000; ++i) answered += notices.refused("r" + std::to_string(i), "unknown_robot", t0) ? 1 : 0;
  EXPECT_EQ(answered, 8) << "the overall rate (a burst of per_second)";
  // Tokens again, but the table is full (16 ids, 8 of them noticed less than 60 s ago): a new id waits.
  EXPECT_FALSE(notices.refused("new", "unknown_robot", t0 + seconds(2)));
  EXPECT_TRUE(notices.refused("r3", "unknown_robot", t0 + seconds(2))) << "an id in the table is answered";
  // Once the noticed ids are forgotten, a new id finds room.
  EXPECT_TRUE(notices.refused("new", "unknown_robot", t0 + seconds(70)));
  EXPECT_EQ(notices.sent(), 10u);
}

}  // namespace
}  // namespace rgbdmap
