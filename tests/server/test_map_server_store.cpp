// A full disk under the running server: the failed append is not acknowledged, nor is any
// keyframe while the store is failed (the robot keeps them and resends); once space is back the server's
// retry recovers the store by itself, the resent keyframes are stored and acknowledged, and a restart finds
// every one of them. The disk fills by a file size limit (RLIMIT_FSIZE: the writes really fail part-way).
#include <chrono>
#include <filesystem>
#include <functional>
#include <thread>

#include <gtest/gtest.h>

#include "common/file_size_limit.hpp"
#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::eventually;
using testing::freshDir;
using testing::kLoopFrames;
using testing::loopSegment;
using testing::OdometrySegment;
using testing::ScriptedRobot;

RGBDMAP_TEST_TIER("MapServerStore.*", "e2e");
RGBDMAP_TEST_TIER("MapServerStore.AFullDiskStopsAcksUntilTheRetryRecoversTheStore", "e2e sanitize");
TEST(MapServerStore, AFullDiskStopsAcksUntilTheRetryRecoversTheStore) {
  const OdometrySegment& seg = loopSegment(kLoopFrames, 0, kLoopFrames);
  ASSERT_GE(seg.keyframes.size(), 12u);
  const std::string dir = freshDir("store_full");
  MapServerConfig config = testing::serverTestConfig(dir);
  config.occupancy_enabled = false;
  config.store_retry_s = 0.1;
  testing::ServerHarness h(config);
  ScriptedRobot robot(*h.transport, "robot0", testing::testKey(1), 100);
  testing::driveRobot(*h.server, robot, seg, 0, 6);
  ASSERT_EQ(h.server->stats().keyframes, 6);

  std::set<int> later;
  for (size_t i = 6; i < 12; ++i) later.insert(seg.keyframes[i].keyframe_id);
  {
    testing::FileSizeLimit full(std::filesystem::file_size(dir + "/keyframes.log") + 1000);
    ASSERT_TRUE(full.ok());
    for (size_t i = 6; i < 12; ++i) robot.send(seg.keyframes[i]);
    // Delivery is asynchronous: wait for the server to have seen all six.
    ASSERT_TRUE(eventually([&] { return h.server->stats().keyframes_unacked_store_failed >= 5; }, 60.0));
    ASSERT_TRUE(h.server->waitIdle(60.0));
    const MapServerStats s = h.server->stats();
    EXPECT_TRUE(s.store_failed);
    EXPECT_NE(s.store_error, "");
    EXPECT_EQ(s.store_failures, 1u);
    EXPECT_EQ(s.keyframes, 6);
    EXPECT_EQ(s.keyframes_unacked_store_failed, 5u);  // the first of the six failed in the append itself
    for (const auto& [id, accepted] : robot.acks()) EXPECT_EQ(later.count(id), 0u) << "acknowledged " << id;
  }
  // Space is back: the retry (every 0.1 s) recovers the store without any keyframe arriving.
  ASSERT_TRUE(eventually([&] { return !h.server->stats().store_failed; }, 30.0))
      << "the store never recovered";
  MapServerStats s = h.server->stats();
  EXPECT_EQ(s.store_recoveries, 1u);
  EXPECT_EQ(s.store_error, "");
  // The robot resends what was not acknowledged: stored and acknowledged now.
  testing::driveRobot(*h.server, robot, seg, 6, 12);
  for (int id : later) EXPECT_TRUE(robot.acks().count(id) && robot.acks().at(id)) << id;
  s = h.server->stats();
  EXPECT_EQ(s.keyframes, 12);
  EXPECT_EQ(s.keyframes_waiting, 0);
  EXPECT_EQ(s.maps, 1);
  std::printf("[ measured ] full disk: %llu keyframes left unacknowledged, %llu recovery attempts\n",
              static_cast<unsigned long long>(s.keyframes_unacked_store_failed),
              static_cast<unsigned long long>(s.store_recover_attempts));

  h.server->stop();
  h.server.reset();
  h.start(config);
  ASSERT_TRUE(h.server->waitIdle(60.0));
  s = h.server->stats();
  EXPECT_EQ(s.restored_keyframes, 12);
  EXPECT_EQ(s.recovery.corrupt_records, 0);
  EXPECT_EQ(s.recovery.truncated_bytes, 0);
  EXPECT_FALSE(s.store_failed);
}

}  // namespace
}  // namespace rgbdmap
