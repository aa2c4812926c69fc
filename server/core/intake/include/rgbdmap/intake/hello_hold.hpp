#pragma once
// Keyframes that arrive before their robot's Hello (the Hello was lost or overtaken). The server cannot
// check or decode them without the camera the Hello announces, and dropping them makes the robot spend
// retransmissions on a link that may be losing most messages, so they are held here, bounded per robot
// (count and bytes, the oldest dropped first; copies of one keyframe held once) and taken in when the Hello
// comes. Not thread-safe: the ingest pipeline's lock guards it.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "rgbdmap/intake/intake_stats.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

class HelloHold {
 public:
  static constexpr size_t kMaxRobots =
      64;  ///< robots with keyframes held at once (open mode has no key list)

  HelloHold(size_t max_per_robot, size_t max_bytes_per_robot)
      : max_per_robot_(max_per_robot), max_bytes_per_robot_(max_bytes_per_robot) {}

  /// Holds `kf` (authenticated, its robot has no Hello yet). False: not held (a copy is held already, or it
  /// alone is over the byte bound, or kMaxRobots other robots have keyframes held).
  bool hold(msg::Keyframe kf);
  /// Everything held for `robot_id`, oldest first; the robot's hold is emptied.
  std::vector<msg::Keyframe> release(const std::string& robot_id);

  size_t held() const;                           ///< keyframes held now, all robots
  uint64_t dropped() const { return dropped_; }  ///< pushed out by the bounds
  HelloHoldStats stats() const { return {static_cast<int>(held()), dropped_}; }

  static size_t bytesOf(const msg::Keyframe& kf);

 private:
  struct Robot {
    std::deque<msg::Keyframe> keyframes;
    size_t bytes = 0;
  };
  size_t max_per_robot_;
  size_t max_bytes_per_robot_;
  std::map<std::string, Robot> robots_;
  uint64_t dropped_ = 0;
};

}  // namespace rgbdmap
