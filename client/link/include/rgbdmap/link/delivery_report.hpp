#pragma once
// Whether a robot run delivered every keyframe, and if not, how many did not get through and the most
// likely reason, in words for the robot's operator (rgbdmap-client prints it and exits non-zero).
#include <string>

#include "rgbdmap/link/robot_runner.hpp"

namespace rgbdmap {

struct DeliveryReport {
  int keyframes = 0;   ///< made by the odometry
  int unaccepted = 0;  ///< not accepted by a server: refused, given up, unanswered at the end, or not sent
  /// In the robot's keyframe spool at the end (this run's and an earlier run's): the next start sends them.
  int spooled = 0;
  /// Refused, or unanswered and not spooled (sent live only, or not sent): the map never gets them.
  int lost = 0;
  bool server_heard = false;
  /// The run failed its job (rgbdmap-client exit 3): keyframes lost, or not accepted with no server heard at
  /// all (a configuration mistake: transport, robot id, key; the spooled ones wait for it to be fixed).
  bool failed() const { return lost > 0 || (unaccepted > 0 && !server_heard); }
  /// "" when every keyframe was accepted; else the count and why: the server says it does not serve this
  /// robot (an unsigned notice), the server reports bad signatures from
  /// this robot (wrong key?), no server heard at all (transport, robot id or key), or a server heard that
  /// refused keyframes ("refused: <reasons>") or did not answer them ("server heard but no ack (loss?)"),
  /// and how many of them are spooled for the next start.
  std::string message;
};

/// `robot_id` names the robot in the message ("this robot" when empty). The server's own counters for this
/// robot (RobotLinkStats::server_rejects, from its status) come first: bad signatures mean the keys differ.
/// A server never heard that sent a "not serving" notice comes before that.
DeliveryReport deliveryReport(const RobotRunResult& result, const std::string& robot_id = "");

/// The reasons of a server's unsigned "not serving" notice: "unknown_robot" (not in server.robots) and
/// "unknown_sender" (no key for the robot).
bool isNotServedReason(const std::string& reason);
/// Why a server says it does not serve this robot, from its notice (RobotLinkStats::server_rejects), or ""
/// when none said so.
std::string notServedReason(const RobotLinkStats& link);

}  // namespace rgbdmap
