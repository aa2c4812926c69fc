// RobotLink's camera mount (sent in Hello, the map frame before any correction) and its live pose
// (RobotPose, throttled, T_map_odom applied) against the fake server over memq://.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "fake_map_server.hpp"
#include "link_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::FakeMapServer;
using testing::FakeServerOptions;
using testing::linkKey;
using testing::linkOptions;
using testing::sendKeyframes;
using testing::serverOptions;
using testing::testPose;

TEST(RobotLink, HelloCarriesTheCameraMountAndLivePosesAreThrottled) {
  auto transport = testing::makeMemq();
  FakeServerOptions so = serverOptions(linkKey(4));
  so.T_map_odom = {{0, testPose(7)}};
  FakeMapServer server(*transport, so);
  server.start();
  RobotLinkOptions lo = linkOptions("robot0", linkKey(4));
  lo.T_base_camera = CameraMount{{0.1, 0.0, 0.3}, {0.0, 10.0, 0.0}}.T_base_camera();
  lo.pose_period_s = 0.1;
  RobotLink link(*transport, lo);
  ASSERT_TRUE(link.start());
  ASSERT_TRUE(server.waitFor([](auto& s) { return s.hellos >= 1; }));
  {
    std::lock_guard<std::mutex> lock(server.state().mutex);
    EXPECT_LT(testing::maxPoseDifference(server.state().last_hello.T_base_camera, lo.T_base_camera), 1e-12);
  }
  EXPECT_LT(testing::maxPoseDifference(link.mapFromOdom(0), lo.T_base_camera), 1e-12);
  // Before a correction the pose is T_base_camera * T_odom_cam; 30 frames within ~0.3 s: a few poses only.
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < 30; ++i) {
    ASSERT_TRUE(link.publishPose(100.0 + i / 30.0, 0, 0, TrackingState::kTracking, testPose(i)));
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const uint64_t sent = link.stats().poses_sent;
  ASSERT_TRUE(server.waitFor([&](auto& s) { return s.poses.size() == sent; })) << sent << " sent";
  {
    std::lock_guard<std::mutex> lock(server.state().mutex);
    const auto& poses = server.state().poses;
    EXPECT_LE(poses.size(), static_cast<size_t>(elapsed / 0.1) + 1) << "at most one per pose_period_s";
    EXPECT_GE(poses.size(), 2u);
    EXPECT_EQ(poses.front().robot_id, "robot0");
    EXPECT_EQ(poses.front().timestamp, 100.0);
    EXPECT_EQ(poses.front().graph_revision, -1);
    EXPECT_LT(testing::maxPoseDifference(poses.front().T_map_cam, lo.T_base_camera * testPose(0)), 1e-9);
  }
  // After a correction: T_map_odom of the segment applied, and the corrections' revision named.
  sendKeyframes(link, 1, 0, 0);
  ASSERT_TRUE(link.waitForCorrection(0, 5.0));
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  ASSERT_TRUE(link.publishPose(200.0, 0, 0, TrackingState::kTracking, testPose(3)));
  ASSERT_TRUE(server.waitFor([](auto& s) { return s.poses.back().timestamp == 200.0; }));
  std::lock_guard<std::mutex> lock(server.state().mutex);
  EXPECT_LT(testing::maxPoseDifference(server.state().poses.back().T_map_cam, testPose(7) * testPose(3)),
            1e-9);
  EXPECT_EQ(server.state().poses.back().graph_revision, link.stats().graph_revision);
}

TEST(RobotLink, NoLivePosesWhenTheyAreOff) {
  auto transport = testing::makeMemq();
  FakeMapServer server(*transport, serverOptions(linkKey(4)));
  server.start();
  RobotLinkOptions lo = linkOptions("robot0", linkKey(4));
  lo.pose_period_s = 0.0;
  RobotLink link(*transport, lo);
  ASSERT_TRUE(link.start());
  for (int i = 0; i < 5; ++i) EXPECT_TRUE(link.publishPose(i, 0, 0, TrackingState::kTracking, testPose(i)));
  EXPECT_EQ(link.stats().poses_sent, 0u);
  link.stop();
  RobotLinkOptions off_link = linkOptions("robot0", linkKey(4));
  RobotLink stopped(*transport, off_link);
  EXPECT_FALSE(stopped.publishPose(0, 0, 0, TrackingState::kTracking, testPose(0))) << "not started";
}

}  // namespace
}  // namespace rgbdmap
