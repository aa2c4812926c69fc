#include "rgbdmap/client/avoidance_config_table.hpp"

namespace rgbdmap {

const ConfigTable<AvoidanceConfig>& avoidanceConfigTable() {
  using C = AvoidanceConfig;
  using R = ConfigRange;
  const R unit = R::closed(-1.0, 1.0);
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("safety_distance_m", &C::safety_distance_m, R::above(0.0),
               "closest obstacle in the corridor at or below this: turn")
          .add("corridor_width_m", &C::corridor_width_m, R::openClosed(0.0, 10.0),
               "robot width plus a margin, centred on the camera")
          .add("lookahead_m", &C::lookahead_m, R::openClosed(0.0, 50.0),
               "obstacles farther ahead are ignored (must be > safety_distance_m)")
          .add("forward_throttle", &C::forward_throttle, unit, "the paper's normalised commands per state")
          .add("forward_yaw", &C::forward_yaw, unit, "")
          .add("turn_throttle", &C::turn_throttle, unit, "")
          .add("turn_yaw", &C::turn_yaw, unit, "")
          .add("back_throttle", &C::back_throttle, unit, "")
          .add("back_yaw", &C::back_yaw, unit, "")
          .add("turn_min_duration_s", &C::turn_min_duration_s, R::atLeast(0.0),
               "turn-left lasts this long before \"still too close\" means back-right")
          .add("clear_hysteresis_m", &C::clear_hysteresis_m, R::atLeast(0.0),
               "back-right ends when clear beyond safety + this")
          .add("emergency_distance_m", &C::emergency_distance_m, R::atLeast(0.0),
               "closer: back-right from any state; 0 = off (must be < safety_distance_m)")
          .add("unknown_is_obstacle", &C::unknown_is_obstacle, "drive only into space observed free")
          .add("max_slice_age_s", &C::max_slice_age_s, R::above(0.0),
               "older (or future) slices stop the robot")
          .add("max_speed_mps", &C::max_speed_mps, R::openClosed(0.0, msg::kMaxSpeed), "throttle 1 in m/s")
          .add("max_yaw_rate_radps", &C::max_yaw_rate_radps, R::openClosed(0.0, msg::kMaxSpeed),
               "yaw 1 in rad/s")
          .add("yaw_is_steering", &C::yaw_is_steering,
               "yaw is a steering angle (reversing turns the other way)")
          .add("command_duration_s", &C::command_duration_s, R::openClosed(0.0, msg::kMaxCommandDuration),
               "the robot stops by itself if no newer command arrives");
  return table;
}

}  // namespace rgbdmap
