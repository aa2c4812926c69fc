// Shared validation rules: ids, text, poses, headers; message type names.
#include <cmath>

#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap::msg {

const char* toString(MessageType type) {
  switch (type) {
    case MessageType::kHello:
      return "Hello";
    case MessageType::kHeartbeat:
      return "Heartbeat";
    case MessageType::kKeyframe:
      return "Keyframe";
    case MessageType::kKeyframeAck:
      return "KeyframeAck";
    case MessageType::kPoseCorrections:
      return "PoseCorrections";
    case MessageType::kOccupancySlice:
      return "OccupancySlice";
    case MessageType::kMapUpdate:
      return "MapUpdate";
    case MessageType::kVelocityCommand:
      return "VelocityCommand";
    case MessageType::kServerStatus:
      return "ServerStatus";
    case MessageType::kKeyframeChunk:
      return "KeyframeChunk";
    case MessageType::kChunkAck:
      return "ChunkAck";
    case MessageType::kLoopEdges:
      return "LoopEdges";
    case MessageType::kRobotPose:
      return "RobotPose";
    case MessageType::kLinkStatus:
      return "LinkStatus";
  }
  return "unknown";
}

bool isKnownType(int type) { return type >= 1 && type <= kNumMessageTypes; }

bool operator==(const Header& a, const Header& b) {
  return a.schema_version == b.schema_version && a.sender == b.sender && a.session == b.session &&
         a.seq == b.seq && a.utime == b.utime;
}

bool isValidId(const std::string& id) {
  if (id.empty() || id.size() > static_cast<size_t>(kMaxIdLength)) return false;
  for (char c : id) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

bool isRobotId(const std::string& id) { return isValidId(id) && id != kServerId; }

bool isValidText(const std::string& text) {
  if (text.size() > static_cast<size_t>(kMaxTextLength)) return false;
  for (char c : text)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

bool isValidPose(const SE3& T) { return se3::isValid(T, 1e-6); }

Status validate(const Header& h) {
  if (h.schema_version != kSchemaVersion) return Status::failure("wrong schema version");
  if (!isValidId(h.sender)) return Status::failure("invalid sender id");
  if (h.seq < 0) return Status::failure("negative seq");
  if (h.utime < 0) return Status::failure("negative utime");
  return Status::success();
}

}  // namespace rgbdmap::msg
