#pragma once
// Whether a robot run delivered every keyframe, and if not, how many did not get through and the most
// likely reason, in words for the robot's operator (rgbdmap-client prints it and exits non-zero).
#include <string>

#include "rgbdmap/link/robot_runner.hpp"

namespace rgbdmap {

struct DeliveryReport {
  int keyframes = 0;   ///< made by the odometry
  int unaccepted = 0;  ///< not accepted by a server: refused, given up, unanswered at the end, or not sent
  bool server_heard = false;
  /// "" when every keyframe was accepted; else the count and why: no server heard at all (transport,
  /// robot id or key), or a server heard that refused keyframes (with its reasons) or did not answer them.
  std::string message;
};

DeliveryReport deliveryReport(const RobotRunResult& result);

}  // namespace rgbdmap
