#pragma once
// Channel names ("rgbdmap/<robot>/<suffix>"). LCM uses them as they are; the DDS adapter maps each to a
// topic name (transport::ddsTopicName: "/" -> "__", other bytes escaped). proto/README.md lists both.
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::msg {

enum class Direction { kRobotToServer, kServerToRobot };
Direction directionOf(MessageType type);

/// `rgbdmap/<robot>/<name>` for per-robot messages, `rgbdmap/server/<name>` for the server's broadcasts
/// (robot_id is ignored for those). Fails for an invalid robot id.
Result<std::string> channelFor(MessageType type, const std::string& robot_id);

/// Short name used in channels: "hello", "keyframe", "pose_corrections", ...
const char* channelSuffix(MessageType type);

/// "rgbdmap/<robot>/<suffix>" -> (robot, suffix), both non-empty; false for anything else.
bool splitChannel(const std::string& channel, std::string* robot, std::string* suffix);

}  // namespace rgbdmap::msg
