// The reactive avoidance rule (Lin et al. 2017, section 3) on crafted slices: corridor distance, the
// forward / turn-left / back-right transitions, unknown cells, stale slices, the VelocityCommand mapping.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "avoidance_test_util.hpp"
#include "rgbdmap/client/avoidance.hpp"
#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap {
namespace {

using testing::levelCamera;
using testing::robotCentredSlice;
using testing::setCellAt;

constexpr double kRes = 0.05;
constexpr double kNow = 1000.0;

const SE3 kCam = levelCamera(Vec3(-0.2, -0.3, 0.0), Vec3(1, 0, 0));  // looking along map x (z is up)

/// A free slice, stamped now, with a wall across the corridor `ahead_m` in front of the camera (0 = none).
msg::OccupancySlice sliceWithWall(double ahead_m, const SE3& cam = kCam, double now = kNow) {
  msg::OccupancySlice s = robotCentredSlice(cam, 4.0, kRes, msg::OccupancySlice::kFree);
  s.header.utime = static_cast<int64_t>(now * 1e6);
  if (ahead_m > 0.0) {
    const Vec3 f = cam.linear().col(2), left = -cam.linear().col(0);
    for (double lateral = -1.0; lateral <= 1.0; lateral += kRes / 2)
      setCellAt(&s, cam.translation() + (ahead_m + kRes / 2) * f + lateral * left,
                msg::OccupancySlice::kOccupied);
  }
  return s;
}

/// The paper's four rules alone: no minimum turn time, no hysteresis, no emergency distance.
AvoidanceConfig paperConfig() {
  AvoidanceConfig c;
  c.turn_min_duration_s = 0.0;
  c.clear_hysteresis_m = 0.0;
  c.emergency_distance_m = 0.0;
  return c;
}

TEST(Avoidance, CorridorDistanceToTheNearEdgeOfTheClosestObstacle) {
  for (double d : {0.3, 0.8, 1.55}) {
    const double got = closestObstacleInCorridor(sliceWithWall(d), kCam, 0.5, 2.0, Vec3(0, 0, 1));
    EXPECT_NEAR(got, d, kRes + 1e-9) << "wall at " << d;
  }
  EXPECT_TRUE(std::isinf(closestObstacleInCorridor(sliceWithWall(0.0), kCam, 0.5, 2.0, Vec3(0, 0, 1))));
  EXPECT_TRUE(std::isinf(closestObstacleInCorridor(sliceWithWall(1.8), kCam, 0.5, 1.5, Vec3(0, 0, 1))))
      << "beyond the lookahead";
  // A grid that is not aligned with the robot: the camera turned 40 degrees in the plane, grid kept.
  const SE3 turned = levelCamera(kCam.translation(), Vec3(std::cos(0.7), -std::sin(0.7), 0));
  msg::OccupancySlice s = sliceWithWall(0.0);
  for (double lateral = -0.5; lateral <= 0.5; lateral += kRes / 2)
    setCellAt(&s, turned.translation() + 0.9 * turned.linear().col(2) - lateral * turned.linear().col(0),
              100);
  EXPECT_NEAR(closestObstacleInCorridor(s, turned, 0.5, 2.0, Vec3(0, 0, 1)), 0.9, 1.5 * kRes);
  // Malformed input is NaN, not a crash.
  s.cells.pop_back();
  EXPECT_TRUE(std::isnan(closestObstacleInCorridor(s, kCam, 0.5, 2.0, Vec3(0, 0, 1))));
  EXPECT_TRUE(std::isnan(closestObstacleInCorridor(sliceWithWall(1.0), kCam, -1.0, 2.0, Vec3(0, 0, 1))));
  EXPECT_TRUE(std::isnan(closestObstacleInCorridor(sliceWithWall(1.0), kCam, 0.5, 2.0, Vec3::Zero())));
  const SE3 down =
      levelCamera(kCam.translation(), Vec3(1, 0, 0)) * SE3(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()));
  EXPECT_TRUE(std::isnan(closestObstacleInCorridor(sliceWithWall(1.0), down, 0.5, 2.0, Vec3(0, 0, 1))))
      << "camera looking straight down has no forward";
}

TEST(Avoidance, ClearCorridorDrivesForward) {
  AvoidanceController c(AvoidanceConfig{});
  const AvoidanceDecision d = c.update(sliceWithWall(0.0), kCam, kNow);
  EXPECT_EQ(d.state, AvoidanceState::kForward);
  EXPECT_DOUBLE_EQ(d.throttle, 0.4);
  EXPECT_DOUBLE_EQ(d.yaw, 0.0);
  EXPECT_TRUE(std::isinf(d.closest_obstacle_m));
  EXPECT_FALSE(d.stopped);
  EXPECT_FALSE(d.slice_stale);
  // A wall beyond the safety distance changes nothing.
  EXPECT_EQ(c.update(sliceWithWall(1.2), kCam, kNow + 0.1).state, AvoidanceState::kForward);
}

TEST(Avoidance, WallWithinSafetyDistanceTurnsLeft) {
  AvoidanceController c(AvoidanceConfig{});
  const AvoidanceDecision d = c.update(sliceWithWall(0.6), kCam, kNow);
  EXPECT_EQ(d.state, AvoidanceState::kTurnLeft);
  EXPECT_TRUE(d.state_changed);
  EXPECT_DOUBLE_EQ(d.throttle, 0.4);
  EXPECT_DOUBLE_EQ(d.yaw, -0.6);
  EXPECT_NEAR(d.closest_obstacle_m, 0.6, kRes);
}

TEST(Avoidance, VeryCloseBacksRightAtOnce) {
  AvoidanceController c(AvoidanceConfig{});  // emergency distance 0.35 m
  const AvoidanceDecision d = c.update(sliceWithWall(0.2), kCam, kNow);
  EXPECT_EQ(d.state, AvoidanceState::kBackRight);
  EXPECT_DOUBLE_EQ(d.throttle, -0.4);
  EXPECT_DOUBLE_EQ(d.yaw, 0.6);
}

TEST(Avoidance, PaperTransitions) {
  AvoidanceController c(paperConfig());
  auto state = [&](double wall, double t) { return c.update(sliceWithWall(wall, kCam, t), kCam, t).state; };
  EXPECT_EQ(state(0.0, kNow), AvoidanceState::kForward);          // 1) clear and forward -> forward
  EXPECT_EQ(state(0.75, kNow + 0.1), AvoidanceState::kTurnLeft);  // 4) <= safety while going straight
  EXPECT_EQ(state(0.7, kNow + 0.2), AvoidanceState::kBackRight);  // 7) still <= safety while turning left
  EXPECT_EQ(state(0.5, kNow + 0.3), AvoidanceState::kBackRight);  //    stays until clear
  EXPECT_EQ(state(0.85, kNow + 0.4), AvoidanceState::kForward);   // 10) > safety while backing -> forward
  EXPECT_EQ(state(0.6, kNow + 0.5), AvoidanceState::kTurnLeft);
  EXPECT_EQ(state(1.5, kNow + 0.6), AvoidanceState::kForward);  // turning left is moving forward: rule 1
  // Even a very close wall goes through turn-left first when the emergency distance is off.
  EXPECT_EQ(state(0.1, kNow + 0.7), AvoidanceState::kTurnLeft);
}

TEST(Avoidance, TurnLastsItsMinimumAndBackingOffHasHysteresis) {
  AvoidanceConfig cfg;
  cfg.turn_min_duration_s = 1.0;
  cfg.clear_hysteresis_m = 0.2;
  AvoidanceController c(cfg);
  auto state = [&](double wall, double t) { return c.update(sliceWithWall(wall, kCam, t), kCam, t).state; };
  EXPECT_EQ(state(0.7, kNow), AvoidanceState::kTurnLeft);
  EXPECT_EQ(state(0.7, kNow + 0.5), AvoidanceState::kTurnLeft) << "turning for only 0.5 s";
  EXPECT_EQ(state(0.7, kNow + 1.0), AvoidanceState::kBackRight) << "still too close after a 1 s turn";
  EXPECT_EQ(state(0.9, kNow + 1.1), AvoidanceState::kBackRight) << "0.9 m is within safety + hysteresis";
  EXPECT_EQ(state(1.1, kNow + 1.2), AvoidanceState::kForward);
}

TEST(Avoidance, ObstaclesOutsideTheCorridorOrBehindAreIgnored) {
  const Vec3 f = kCam.linear().col(2), left = -kCam.linear().col(0);
  msg::OccupancySlice s = sliceWithWall(0.0);
  ASSERT_TRUE(setCellAt(&s, kCam.translation() + 0.5 * f + 0.45 * left, 100));  // beside the corridor
  ASSERT_TRUE(setCellAt(&s, kCam.translation() + 0.5 * f - 0.45 * left, 100));
  ASSERT_TRUE(setCellAt(&s, kCam.translation() - 0.3 * f, 100));              // behind
  ASSERT_TRUE(setCellAt(&s, kCam.translation() + 0.5 * f + 0.1 * left, 60));  // occupancy 60 >= 50: obstacle
  AvoidanceController c(AvoidanceConfig{});
  AvoidanceDecision d = c.update(s, kCam, kNow);
  EXPECT_NEAR(d.closest_obstacle_m, 0.5, kRes);
  EXPECT_EQ(d.state, AvoidanceState::kTurnLeft);
  ASSERT_TRUE(setCellAt(&s, kCam.translation() + 0.5 * f + 0.1 * left, 40));  // 40 < 50: not an obstacle
  AvoidanceController c2(AvoidanceConfig{});
  d = c2.update(s, kCam, kNow);
  EXPECT_TRUE(std::isinf(d.closest_obstacle_m)) << d.closest_obstacle_m;
  EXPECT_EQ(d.state, AvoidanceState::kForward);
  // Just inside the corridor's edge (width 0.5: lateral 0.2 + half a cell) counts.
  ASSERT_TRUE(setCellAt(&s, kCam.translation() + 0.7 * f - 0.22 * left, 100));
  EXPECT_NEAR(c2.update(s, kCam, kNow).closest_obstacle_m, 0.7, kRes);
}

TEST(Avoidance, UnknownCellsAreFreeUnlessConfiguredAsObstacles) {
  msg::OccupancySlice unknown = robotCentredSlice(kCam, 4.0, kRes, msg::OccupancySlice::kUnknown);
  unknown.header.utime = static_cast<int64_t>(kNow * 1e6);
  AvoidanceController optimistic(AvoidanceConfig{});
  AvoidanceDecision d = optimistic.update(unknown, kCam, kNow);
  EXPECT_EQ(d.state, AvoidanceState::kForward);
  EXPECT_TRUE(std::isinf(d.closest_obstacle_m));
  AvoidanceConfig cautious_cfg;
  cautious_cfg.unknown_is_obstacle = true;
  AvoidanceController cautious(cautious_cfg);
  d = cautious.update(unknown, kCam, kNow);
  EXPECT_DOUBLE_EQ(d.closest_obstacle_m, 0.0);
  EXPECT_EQ(d.state, AvoidanceState::kBackRight);
  // Observed free space up to 1.5 m, unknown beyond: the cautious robot sees an obstacle at 1.5 m.
  for (double a = -0.5; a < 1.5; a += kRes / 2)
    for (double l = -0.5; l <= 0.5; l += kRes / 2)
      setCellAt(&unknown, kCam.translation() + a * kCam.linear().col(2) + l * kCam.linear().col(0), 0);
  AvoidanceController cautious2(cautious_cfg);
  EXPECT_NEAR(cautious2.update(unknown, kCam, kNow).closest_obstacle_m, 1.5, kRes);
}

TEST(Avoidance, StaleMissingOrBadSliceStopsAndSaysSo) {
  AvoidanceController c(AvoidanceConfig{});
  ASSERT_EQ(c.update(sliceWithWall(0.6), kCam, kNow).state, AvoidanceState::kTurnLeft);
  auto expectStop = [&](const AvoidanceDecision& d, bool stale, const std::string& why) {
    EXPECT_TRUE(d.stopped) << why;
    EXPECT_EQ(d.slice_stale, stale) << why;
    EXPECT_EQ(d.throttle, 0.0) << why;
    EXPECT_EQ(d.yaw, 0.0) << why;
    EXPECT_NE(d.reason.find(why), std::string::npos) << d.reason;
    EXPECT_EQ(d.state, AvoidanceState::kTurnLeft) << "the state is kept while stopped";
    const msg::VelocityCommand cmd = c.command(d, "robot0");
    EXPECT_EQ(cmd.linear_mps, Vec3::Zero());
    EXPECT_EQ(cmd.angular_radps, Vec3::Zero());
  };
  expectStop(c.update(sliceWithWall(0.6, kCam, kNow), kCam, kNow + 1.5), true, "stale");
  expectStop(c.update(sliceWithWall(0.6, kCam, kNow + 5.0), kCam, kNow), true, "future");
  expectStop(c.update(msg::OccupancySlice{}, kCam, kNow), true, "no slice");
  msg::OccupancySlice broken = sliceWithWall(0.6);
  broken.width += 1;
  expectStop(c.update(broken, kCam, kNow), true, "malformed");
  SE3 nan_pose = kCam;
  nan_pose.translation().x() = NAN;
  expectStop(c.update(sliceWithWall(0.6), nan_pose, kNow), false, "pose");
  expectStop(c.update(sliceWithWall(0.6), kCam, NAN), false, "time");
  // A fresh slice again: the machine continues where it was.
  EXPECT_EQ(c.update(sliceWithWall(0.6), kCam, kNow + 0.05).state, AvoidanceState::kTurnLeft);
}

TEST(Avoidance, CommandsAreBodyTwistsInRosConvention) {
  AvoidanceConfig cfg;
  cfg.max_speed_mps = 0.5;
  cfg.max_yaw_rate_radps = 1.0;
  AvoidanceController c(cfg);
  msg::VelocityCommand fwd = c.command(c.update(sliceWithWall(0.0), kCam, kNow), "robot0");
  EXPECT_NEAR(fwd.linear_mps.x(), 0.2, 1e-12);
  EXPECT_EQ(fwd.angular_radps, Vec3::Zero());
  EXPECT_EQ(fwd.robot_id, "robot0");
  EXPECT_EQ(fwd.header.utime, static_cast<int64_t>(kNow * 1e6));
  EXPECT_DOUBLE_EQ(fwd.duration_s, 0.5);
  const msg::VelocityCommand left = c.command(c.update(sliceWithWall(0.6), kCam, kNow), "robot0");
  EXPECT_NEAR(left.linear_mps.x(), 0.2, 1e-12);
  EXPECT_NEAR(left.angular_radps.z(), 0.6, 1e-12) << "yaw -0.6 = left = counter-clockwise = +z";
  const AvoidanceDecision back = c.update(sliceWithWall(0.2), kCam, kNow);
  ASSERT_EQ(back.state, AvoidanceState::kBackRight);
  const msg::VelocityCommand steer = c.command(back, "robot0");
  EXPECT_NEAR(steer.linear_mps.x(), -0.2, 1e-12);
  EXPECT_NEAR(steer.angular_radps.z(), 0.6, 1e-12) << "reversing with right steering turns the nose left";
  cfg.yaw_is_steering = false;
  EXPECT_NEAR(AvoidanceController(cfg).command(back, "robot0").angular_radps.z(), -0.6, 1e-12);
  // What the controller makes passes the message validation once the server's header is on it.
  msg::VelocityCommand sealed = steer;
  sealed.header.sender = msg::kServerId;
  sealed.header.session = 1;
  sealed.header.seq = 1;
  EXPECT_TRUE(msg::validate(sealed)) << msg::validate(sealed).error();
}

TEST(Avoidance, ConfigValidationReportsEveryProblem) {
  EXPECT_EQ(AvoidanceConfig{}.validate(), "");
  AvoidanceConfig bad;
  bad.safety_distance_m = -1.0;
  bad.turn_yaw = 3.0;
  bad.max_slice_age_s = NAN;
  bad.up_in_map = Vec3::Zero();
  const std::string reasons = bad.validate();
  for (const char* key : {"safety_distance_m", "turn_yaw", "max_slice_age_s", "up_in_map"})
    EXPECT_NE(reasons.find(key), std::string::npos) << key << " in: " << reasons;
  AvoidanceController c(bad);
  const AvoidanceDecision d = c.update(sliceWithWall(0.0), kCam, kNow);
  EXPECT_TRUE(d.stopped);
  EXPECT_NE(d.reason.find("invalid avoidance config"), std::string::npos);
  EXPECT_EQ(c.command(d, "robot0").linear_mps, Vec3::Zero());
}

}  // namespace
}  // namespace rgbdmap
