// Lin et al. 2017 section 3: reactive avoidance on the latest occupancy slice.
#include "rgbdmap/client/avoidance.hpp"

#include "rgbdmap/client/avoidance_config_table.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

namespace rgbdmap {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kObstacleMinOccupancy = 50;

bool usableGrid(const msg::OccupancySlice& s) {
  return s.width >= 1 && s.height >= 1 && s.width <= msg::kMaxGridSide && s.height <= msg::kMaxGridSide &&
         s.cells.size() == static_cast<size_t>(s.width) * static_cast<size_t>(s.height) &&
         std::isfinite(s.resolution_m) && s.resolution_m > 0.0f && se3::isValid(s.T_map_grid);
}

std::string fmt(double v) {
  std::ostringstream o;
  o.precision(3);
  o << v;
  return o.str();
}

void check(bool ok, const char* what, std::vector<std::string>* bad) {
  if (!ok) bad->emplace_back(what);
}

}  // namespace

const char* toString(AvoidanceState state) {
  switch (state) {
    case AvoidanceState::kForward:
      return "forward";
    case AvoidanceState::kTurnLeft:
      return "turn_left";
    case AvoidanceState::kBackRight:
      return "back_right";
  }
  return "unknown";
}

std::string AvoidanceConfig::validate() const {
  std::vector<std::string> bad = avoidanceConfigTable().problems(*this);
  check(lookahead_m > safety_distance_m, "lookahead_m must be above safety_distance_m", &bad);
  check(emergency_distance_m < safety_distance_m, "emergency_distance_m must be below safety_distance_m",
        &bad);
  check(up_in_map.allFinite() && up_in_map.norm() > 1e-6, "up_in_map must be a finite non-zero vector", &bad);
  return joinProblems(bad);
}

double closestObstacleInCorridor(const msg::OccupancySlice& slice, const SE3& T_map_cam, double width_m,
                                 double lookahead_m, Vec3 up_in_map, bool unknown_is_obstacle) {
  if (!usableGrid(slice) || !se3::isValid(T_map_cam) || !(width_m > 0.0) || !(lookahead_m > 0.0) ||
      !std::isfinite(width_m) || !std::isfinite(lookahead_m) || !up_in_map.allFinite() ||
      up_in_map.norm() < 1e-9)
    return kNaN;
  const Vec3 up = up_in_map.normalized();
  const Vec3 forward_map = T_map_cam.linear().col(2) - up * up.dot(T_map_cam.linear().col(2));
  if (forward_map.norm() < 1e-3) return kNaN;
  const SE3 T_grid_map = slice.T_map_grid.inverse();
  const Vec3 cam_grid = T_grid_map * T_map_cam.translation();
  const Vec3 f_grid = T_grid_map.linear() * forward_map;
  const Vec3 left_grid = T_grid_map.linear() * up.cross(forward_map);
  if (f_grid.head<2>().norm() < 1e-6) return kNaN;  // the grid is not horizontal
  const Eigen::Vector2d c = cam_grid.head<2>(), f = f_grid.head<2>().normalized();
  Eigen::Vector2d l(-f.y(), f.x());
  if (l.dot(left_grid.head<2>()) < 0.0) l = -l;

  const double res = slice.resolution_m, half_w = width_m / 2.0;
  // Bounding box of the corridor rectangle, in cells.
  double x_min = kInf, x_max = -kInf, y_min = kInf, y_max = -kInf;
  for (double a : {0.0, lookahead_m})
    for (double b : {-half_w, half_w}) {
      const Eigen::Vector2d p = c + a * f + b * l;
      x_min = std::min(x_min, p.x()), x_max = std::max(x_max, p.x());
      y_min = std::min(y_min, p.y()), y_max = std::max(y_max, p.y());
    }
  const int col0 = std::max(0, static_cast<int>(std::floor(x_min / res)) - 1);
  const int col1 = std::min(slice.width - 1, static_cast<int>(std::floor(x_max / res)) + 1);
  const int row0 = std::max(0, static_cast<int>(std::floor(y_min / res)) - 1);
  const int row1 = std::min(slice.height - 1, static_cast<int>(std::floor(y_max / res)) + 1);
  // Half-extent of a square cell projected onto the forward and lateral directions.
  const double h_f = res / 2.0 * (std::abs(f.x()) + std::abs(f.y()));
  const double h_l = res / 2.0 * (std::abs(l.x()) + std::abs(l.y()));
  double closest = kInf;
  for (int row = row0; row <= row1; ++row)
    for (int col = col0; col <= col1; ++col) {
      const int8_t v = slice.cells[static_cast<size_t>(row) * slice.width + col];
      if (!(v >= kObstacleMinOccupancy || (unknown_is_obstacle && v < 0))) continue;
      const Eigen::Vector2d d = Eigen::Vector2d((col + 0.5) * res, (row + 0.5) * res) - c;
      const double ahead = d.dot(f), lateral = d.dot(l);
      if (ahead + h_f <= 0.0 || ahead - h_f > lookahead_m || std::abs(lateral) - h_l > half_w) continue;
      closest = std::min(closest, std::max(0.0, ahead - h_f));
    }
  return closest;
}

AvoidanceController::AvoidanceController(AvoidanceConfig config)
    : config_(std::move(config)), config_error_(config_.validate()) {}

AvoidanceDecision AvoidanceController::stop(AvoidanceDecision d, std::string reason) const {
  d.throttle = 0.0;
  d.yaw = 0.0;
  d.stopped = true;
  d.reason = std::move(reason);
  return d;
}

AvoidanceDecision AvoidanceController::update(const msg::OccupancySlice& slice, const SE3& T_map_cam,
                                              double now_s) {
  AvoidanceDecision d;
  d.state = state_;
  d.now_s = now_s;
  d.closest_obstacle_m = kNaN;
  if (!config_error_.empty()) return stop(d, "invalid avoidance config: " + config_error_);
  if (!std::isfinite(now_s)) return stop(d, "invalid time");
  if (!started_) {
    state_since_s_ = now_s;
    started_ = true;
  }
  d.slice_stale = true;
  if (slice.cells.empty()) return stop(d, "no slice yet");
  const double age_s = now_s - static_cast<double>(slice.header.utime) * 1e-6;
  if (age_s > config_.max_slice_age_s) return stop(d, "slice is stale (" + fmt(age_s) + " s old)");
  if (age_s < -config_.max_slice_age_s)
    return stop(d, "slice is from the future (" + fmt(-age_s) + " s ahead)");
  if (!usableGrid(slice)) return stop(d, "slice is malformed");
  d.slice_stale = false;
  if (!se3::isValid(T_map_cam)) return stop(d, "invalid camera pose");
  const double closest =
      closestObstacleInCorridor(slice, T_map_cam, config_.corridor_width_m, config_.lookahead_m,
                                config_.up_in_map, config_.unknown_is_obstacle);
  if (std::isnan(closest)) return stop(d, "camera looks straight up or down, or the slice is not horizontal");
  d.closest_obstacle_m = closest;

  const double safe = config_.safety_distance_m;
  AvoidanceState next = state_;
  if (config_.emergency_distance_m > 0.0 && closest <= config_.emergency_distance_m) {
    next = AvoidanceState::kBackRight;
    d.reason = "obstacle within the emergency distance";
  } else if (state_ == AvoidanceState::kForward) {
    if (closest <= safe) next = AvoidanceState::kTurnLeft, d.reason = "obstacle within the safety distance";
  } else if (state_ == AvoidanceState::kTurnLeft) {
    if (closest > safe) {
      next = AvoidanceState::kForward, d.reason = "clear after turning";
    } else if (now_s - state_since_s_ >= config_.turn_min_duration_s) {
      next = AvoidanceState::kBackRight, d.reason = "still within the safety distance after turning";
    }
  } else if (closest > safe + config_.clear_hysteresis_m) {
    next = AvoidanceState::kForward, d.reason = "clear after backing off";
  }
  if (next != state_) {
    state_ = next;
    state_since_s_ = now_s;
    d.state_changed = true;
  }
  d.state = state_;
  switch (state_) {
    case AvoidanceState::kForward:
      d.throttle = config_.forward_throttle, d.yaw = config_.forward_yaw;
      break;
    case AvoidanceState::kTurnLeft:
      d.throttle = config_.turn_throttle, d.yaw = config_.turn_yaw;
      break;
    case AvoidanceState::kBackRight:
      d.throttle = config_.back_throttle, d.yaw = config_.back_yaw;
      break;
  }
  return d;
}

msg::VelocityCommand AvoidanceController::command(const AvoidanceDecision& decision,
                                                  const std::string& robot_id) const {
  msg::VelocityCommand cmd;
  cmd.robot_id = robot_id;
  cmd.header.utime =
      std::isfinite(decision.now_s) ? static_cast<int64_t>(std::llround(decision.now_s * 1e6)) : 0;
  cmd.duration_s = config_error_.empty() ? config_.command_duration_s : 0.0;
  if (decision.stopped || !config_error_.empty()) return cmd;
  const double steering_sign = (config_.yaw_is_steering && decision.throttle < 0.0) ? -1.0 : 1.0;
  cmd.linear_mps.x() = decision.throttle * config_.max_speed_mps;
  cmd.angular_radps.z() = -decision.yaw * config_.max_yaw_rate_radps * steering_sign;
  return cmd;
}

}  // namespace rgbdmap
