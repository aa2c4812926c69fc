// ReorderBuffer (rgbdmap_server, private): stored keyframes waiting for their odometry predecessor, which
// runs are given up on (timeout, per-robot bound), and forged cycles that must not hang it.
#include <gtest/gtest.h>

#include <chrono>

#include "rgbdmap/ingest/reorder_buffer.hpp"

namespace rgbdmap {
namespace {

using Clock = ReorderBuffer::Clock;

KeyframeKey key(int robot, int id) { return {robot, 7, 0, id}; }

/// Keyframe `id` of `robot`, waiting for id - 1, stored at t0 + `at_s`.
void addWaiting(ReorderBuffer& buffer, int robot, int id, Clock::time_point t0, double at_s) {
  WaitingKeyframe w;
  w.stored.keyframe.keyframe_id = id;
  w.since = t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(at_s));
  buffer.add(key(robot, id), key(robot, id - 1), std::move(w));
}

Clock::time_point after(Clock::time_point t0, double s) {
  return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

TEST(ReorderBuffer, SuccessorsComeOutWhenTheirPredecessorArrives) {
  ReorderBuffer buffer;
  const auto t0 = Clock::now();
  addWaiting(buffer, 0, 5, t0, 0.0);
  addWaiting(buffer, 0, 4, t0, 0.1);
  addWaiting(buffer, 0, 4, t0, 0.2);  // the same keyframe again: held once
  EXPECT_EQ(buffer.size(), 2u);
  EXPECT_TRUE(buffer.contains(key(0, 5)));
  EXPECT_TRUE(buffer.takeSuccessors(key(0, 2)).empty());
  const auto four = buffer.takeSuccessors(key(0, 3));
  ASSERT_EQ(four.size(), 1u);
  EXPECT_EQ(four[0].stored.keyframe.keyframe_id, 4);
  const auto five = buffer.takeSuccessors(key(0, 4));
  ASSERT_EQ(five.size(), 1u);
  EXPECT_EQ(buffer.size(), 0u);
}

TEST(ReorderBuffer, ARunIsGivenUpFromItsHeadAfterTheTimeout) {
  ReorderBuffer buffer;
  const auto t0 = Clock::now();
  addWaiting(buffer, 0, 12, t0, 0.0);  // oldest, but waits for 11, which waits for 10 (missing)
  addWaiting(buffer, 0, 11, t0, 0.5);
  EXPECT_FALSE(buffer.takeRunToGiveUp(after(t0, 0.9), 1.0, 10));
  const auto head = buffer.takeRunToGiveUp(after(t0, 1.0), 1.0, 10);
  ASSERT_TRUE(head);
  EXPECT_EQ(head->stored.keyframe.keyframe_id, 11) << "the run starts where its predecessor is missing";
  EXPECT_EQ(buffer.takeSuccessors(key(0, 11)).size(), 1u);
  EXPECT_FALSE(buffer.takeRunToGiveUp(after(t0, 100.0), 1.0, 10));
}

TEST(ReorderBuffer, ARobotOverItsBoundGivesUpItsOldestRunOthersAreUntouched) {
  ReorderBuffer buffer;
  const auto t0 = Clock::now();
  addWaiting(buffer, 1, 3, t0, 0.0);  // robot 1: one waiting, within the bound
  for (int id : {20, 21, 22}) addWaiting(buffer, 0, id, t0, 0.1 * id);  // run 20-22 waits for 19
  addWaiting(buffer, 0, 40, t0, 3.0);                                   // run 40 waits for 39
  EXPECT_EQ(buffer.waiting(0), 4u);
  EXPECT_FALSE(buffer.takeRunToGiveUp(after(t0, 5.0), 3600.0, 4));
  addWaiting(buffer, 0, 41, t0, 5.0);
  const auto head = buffer.takeRunToGiveUp(after(t0, 5.0), 3600.0, 4);
  ASSERT_TRUE(head);
  EXPECT_EQ(head->stored.keyframe.keyframe_id, 20);
  EXPECT_EQ(buffer.waiting(1), 1u);
}

TEST(ReorderBuffer, AForgedCycleIsGivenUpInsteadOfHanging) {
  ReorderBuffer buffer;
  const auto t0 = Clock::now();
  WaitingKeyframe a, b;
  a.since = b.since = t0;
  buffer.add(key(0, 1), key(0, 2), std::move(a));  // 1 waits for 2, 2 waits for 1
  buffer.add(key(0, 2), key(0, 1), std::move(b));
  const auto head = buffer.takeRunToGiveUp(after(t0, 2.0), 1.0, 10);
  ASSERT_TRUE(head);
  EXPECT_EQ(buffer.size(), 1u);
}

}  // namespace
}  // namespace rgbdmap
