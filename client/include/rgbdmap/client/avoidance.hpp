#pragma once
// Reactive obstacle avoidance of Lin et al. 2017, section 3 ("wandering" avoidance on the map): the closest
// obstacle in a corridor ahead of the robot, taken from the latest occupancy slice, is compared with a
// safety distance, and a three-state machine chooses the paper's throttle/yaw commands:
//
//   forward    (throttle 0.4, yaw 0)     closest >  safety            -> stay forward
//                                        closest <= safety            -> turn-left
//   turn-left  (throttle 0.4, yaw -0.6)  closest >  safety            -> forward (the paper's rule 1: "clear
//                                                                         and moving forward")
//                                        closest <= safety, after the turn has lasted turn_min_duration_s
//                                                                      -> back-right ("still too close after
//                                                                         turning")
//   back-right (throttle -0.4, yaw 0.6)  closest >  safety + clear_hysteresis_m -> forward ("until nothing is
//                                                                         ahead"); otherwise stay
//
// Two additions to the paper, both configurable and off when set to 0: emergency_distance_m (closer than
// this -> back-right from any state: a forward turn would hit it) and the hysteresis above. With
// turn_min_duration_s = 0, emergency_distance_m = 0 and clear_hysteresis_m = 0 the machine is exactly the
// paper's four rules, evaluated once per update.
//
// Units and signs. The paper's throttle and yaw are normalised commands of an RC car (Axial AX10 through a
// Pixhawk): throttle > 0 drives forward, yaw < 0 steers left. VelocityCommand is a body twist in the ROS
// convention (REP 103: x forward, z up, angular z > 0 = counter-clockwise = left):
//   linear_mps.x    = throttle * max_speed_mps
//   angular_radps.z = -yaw * max_yaw_rate_radps * (yaw_is_steering && throttle < 0 ? -1 : 1)
// With yaw_is_steering (default) yaw is a steering angle, as on the paper's car: reversing with the wheels
// turned right swings the nose left, so back-right turns the heading counter-clockwise and the robot leaves
// facing left of the obstacle, as turn-left intended. With yaw_is_steering = false yaw is a turn rate.
//
// Unknown cells. Cells the map has not seen are not obstacles (the camera's blind zone below ~0.4 m and
// the space beside and behind it would otherwise stop the robot at once); unknown_is_obstacle = true makes
// the robot only drive into space it has observed free. Cells with occupancy >= 50 are obstacles.
//
// Algorithms only: plain structs in and out; publishing the command is the caller's business. Cost: only the
// cells under the corridor's bounding box are read, 0.43 us CPU per update whatever the slice size
// (build/bin/bench_avoidance).
#include <string>

#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct AvoidanceConfig {
  /// The paper gives no number; 0.8 m is two lengths of its 1:10 car's stopping-and-turning room and twice
  /// the depth camera's minimum range (obstacles nearer than ~0.4 m are only known from earlier views).
  double safety_distance_m = 0.8;
  double corridor_width_m = 0.5;  ///< robot width (~0.3 m) plus a margin; centred on the camera
  double lookahead_m = 2.0;       ///< obstacles farther ahead are ignored (must be > safety_distance_m)
  double forward_throttle = 0.4, forward_yaw = 0.0;
  double turn_throttle = 0.4, turn_yaw = -0.6;
  double back_throttle = -0.4, back_yaw = 0.6;
  /// Transitions: turn-left must last this long before "still too close" means back-right (0 = next update).
  double turn_min_duration_s = 1.0;
  /// Back-right ends when the corridor is clear beyond safety + this (0 = the paper's rule).
  double clear_hysteresis_m = 0.1;
  /// Closer than this: back-right from any state (0 = off, the paper's rules only).
  double emergency_distance_m = 0.35;
  bool unknown_is_obstacle = false;
  Vec3 up_in_map = Vec3(0, 0, 1);  ///< the map frame is z-up (REP-103)
  /// A slice older than this (header.utime against now_s), or from more than this in the future -> stop.
  double max_slice_age_s = 1.0;
  /// Command scaling (see the header comment) and validity of each command.
  double max_speed_mps = 0.5;
  double max_yaw_rate_radps = 1.0;
  bool yaw_is_steering = true;
  double command_duration_s = 0.5;  ///< the robot stops by itself if no newer command arrives

  /// Empty when every value is in range, else every reason ("; "-separated).
  std::string validate() const;
};

enum class AvoidanceState { kForward, kTurnLeft, kBackRight };
const char* toString(AvoidanceState state);

struct AvoidanceDecision {
  AvoidanceState state = AvoidanceState::kForward;
  double throttle = 0.0, yaw = 0.0;  ///< the paper's normalised commands; 0, 0 when stopped
  double closest_obstacle_m = 0.0;   ///< +inf when the corridor is clear; NaN when not evaluated
  bool slice_stale = false;          ///< missing, too old, from the future, or unusable: stopped
  bool stopped = false;              ///< throttle and yaw forced to 0 (stale slice or invalid pose)
  bool state_changed = false;        ///< this update changed the state
  double now_s = 0.0;
  std::string reason;  ///< why stopped, or which rule fired
};

class AvoidanceController {
 public:
  /// An invalid config (see validate()) makes every update stop with the config's reasons.
  explicit AvoidanceController(AvoidanceConfig config);

  /// Uses the slice and the robot's current camera pose in the map frame. A missing (no cells), stale,
  /// future or malformed slice, or an invalid pose -> stop (throttle 0, yaw 0), say so, keep the state.
  AvoidanceDecision update(const msg::OccupancySlice& slice, const SE3& T_map_cam, double now_s);

  /// The decision as a VelocityCommand for robot_id (header.utime = decision time; sender, session and seq
  /// are the envelope's business).
  msg::VelocityCommand command(const AvoidanceDecision& decision, const std::string& robot_id) const;

  AvoidanceState state() const { return state_; }
  const AvoidanceConfig& config() const { return config_; }

 private:
  AvoidanceDecision stop(AvoidanceDecision d, std::string reason) const;
  AvoidanceConfig config_;
  std::string config_error_;
  AvoidanceState state_ = AvoidanceState::kForward;
  double state_since_s_ = 0.0;
  bool started_ = false;
};

/// Distance from the camera, along the robot's forward direction (camera z projected onto the plane
/// perpendicular to up), to the nearest edge of the closest obstacle cell that overlaps the corridor
/// (|lateral| <= width / 2, 0 < ahead <= lookahead). Cells behind the camera are ignored; a cell the camera
/// is inside counts as 0. +inf when the corridor is clear; NaN for a malformed slice, an invalid pose, a
/// camera looking straight up or down, or non-positive width / lookahead.
double closestObstacleInCorridor(const msg::OccupancySlice& slice, const SE3& T_map_cam, double width_m,
                                 double lookahead_m, Vec3 up_in_map, bool unknown_is_obstacle = false);

}  // namespace rgbdmap
