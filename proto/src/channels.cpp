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
    case MessageType::kKeyframeChunk:
      return "keyframe_chunk";
    case MessageType::kChunkAck:
      return "chunk_ack";
    case MessageType::kLoopEdges:
      return "loops";
    case MessageType::kRobotPose:
      return "pose";
    case MessageType::kLinkStatus:
      return "link";
  }
  return "unknown";
}

Direction directionOf(MessageType type) {
  switch (type) {
    case MessageType::kHello:
    case MessageType::kHeartbeat:
    case MessageType::kKeyframe:
    case MessageType::kKeyframeChunk:
    case MessageType::kRobotPose:   // robot -> visualisers (the server does not subscribe)
    case MessageType::kLinkStatus:  // robot -> monitor, visualisers (likewise)
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

bool splitChannel(const std::string& channel, std::string* robot, std::string* suffix) {
  static const std::string kPrefix = "rgbdmap/";
  if (channel.compare(0, kPrefix.size(), kPrefix) != 0) return false;
  const size_t slash = channel.find('/', kPrefix.size());
  if (slash == std::string::npos) return false;
  *robot = channel.substr(kPrefix.size(), slash - kPrefix.size());
  *suffix = channel.substr(slash + 1);
  return !robot->empty() && !suffix->empty();
}

}  // namespace rgbdmap::msg
