#pragma once
// Wall-clock time as the link stamps envelopes and acknowledgements (private to rgbdmap_robot_link).
#include <chrono>
#include <cstdint>

namespace rgbdmap {

/// Wall-clock time in microseconds (envelope timestamps, RobotLink::keyframeAckTimes).
inline int64_t nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace rgbdmap
