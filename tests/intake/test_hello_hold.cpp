// HelloHold: keyframes that came before their robot's Hello, bounded per robot and in robots.
#include <gtest/gtest.h>

#include "rgbdmap/intake/hello_hold.hpp"

namespace rgbdmap {
namespace {

msg::Keyframe heldKeyframe(const std::string& robot, int id, size_t image_bytes) {
  msg::Keyframe kf;
  kf.robot_id = robot;
  kf.header.session = 7;
  kf.keyframe_id = id;
  kf.images.color.assign(image_bytes, 1);
  return kf;
}

TEST(HelloHold, KeepsOneCopyEachAndReleasesOldestFirst) {
  HelloHold hold(8, 1 << 20);
  EXPECT_TRUE(hold.hold(heldKeyframe("a", 1, 100)));
  EXPECT_FALSE(hold.hold(heldKeyframe("a", 1, 100))) << "a resent copy is held once";
  EXPECT_TRUE(hold.hold(heldKeyframe("a", 2, 100)));
  EXPECT_TRUE(hold.hold(heldKeyframe("b", 1, 100)));
  EXPECT_EQ(hold.held(), 3u);
  const std::vector<msg::Keyframe> a = hold.release("a");
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0].keyframe_id, 1);
  EXPECT_EQ(a[1].keyframe_id, 2);
  EXPECT_TRUE(hold.release("a").empty());
  EXPECT_EQ(hold.held(), 1u);
  EXPECT_EQ(hold.dropped(), 0u);
}

TEST(HelloHold, BoundsCountBytesAndRobots) {
  HelloHold hold(3, 10000);
  for (int id = 0; id < 5; ++id) hold.hold(heldKeyframe("a", id, 100));
  EXPECT_EQ(hold.held(), 3u);
  EXPECT_EQ(hold.dropped(), 2u);
  EXPECT_EQ(hold.release("a").front().keyframe_id, 2) << "the oldest go first";
  EXPECT_FALSE(hold.hold(heldKeyframe("a", 9, 20000))) << "over the byte bound alone";
  for (int id = 0; id < 3; ++id) hold.hold(heldKeyframe("a", id, 4000));
  EXPECT_LE(hold.held(), 2u) << "bytes bound the robot's hold";
  hold.release("a");
  for (size_t r = 0; r < HelloHold::kMaxRobots + 10; ++r)
    hold.hold(heldKeyframe("r" + std::to_string(r), 1, 10));
  EXPECT_EQ(hold.held(), HelloHold::kMaxRobots);
}

}  // namespace
}  // namespace rgbdmap
