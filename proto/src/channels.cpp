// Channel / topic names (the table in proto/README.md).
#include "rgbdmap/proto/channels.hpp"

#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap::msg {

const char* channelSuffix(MessageType type) {
  switch (type) {
    case MessageType::kHello:
      return "hello";
    case MessageType::kHeartbeat:
      return "heartbeat";
    case MessageType::kKeyframe:
      return "keyframe";
    case MessageType::kKeyframeAck:
      return "keyframe_ack";
    case MessageType::kPoseCorrections:
      return "pose_corrections";
    case MessageType::kOccupancySlice:
      return "slice";
    case MessageType::kMapUpdate:
      return "map";
    case MessageType::kVelocityCommand:
      return "cmd_vel";
    case MessageType::kServerStatus:
      return "status";
  }
  return "unknown";
}

Direction directionOf(MessageType type) {
  switch (type) {
    case MessageType::kHello:
    case MessageType::kHeartbeat:
    case MessageType::kKeyframe:
      return Direction::kRobotToServer;
    default:  // everything the server sends goes to one robot's channel, signed with that robot's key
      return Direction::kServerToRobot;
  }
}

Result<std::string> channelFor(MessageType type, const std::string& robot_id) {
  const std::string suffix = channelSuffix(type);
  if (!isRobotId(robot_id)) return Result<std::string>::failure("invalid robot id '" + robot_id + "'");
  return "rgbdmap/" + robot_id + "/" + suffix;
}

}  // namespace rgbdmap::msg
