#pragma once
// Content checks of the internal messages. The decoder runs them on everything it receives; the encoder
// runs them too, so nothing is sent that a receiver would reject. Each returns the first reason found.
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::msg {

/// [A-Za-z0-9_-]{1,32}. `server` is a valid sender id but isRobotId() refuses it.
bool isValidId(const std::string& id);
bool isRobotId(const std::string& id);
/// Printable ASCII, at most kMaxTextLength characters.
bool isValidText(const std::string& text);
/// Finite, rotation orthonormal (within 1e-6).
bool isValidPose(const SE3& T);

Status validate(const Header& header);
Status validate(const Hello& m);
Status validate(const Heartbeat& m);
Status validate(const RobotPose& m);
Status validate(const LinkStatus& m);
Status validate(const Keyframe& m);
Status validate(const KeyframeAck& m);
Status validate(const PoseCorrections& m);
Status validate(const LoopEdges& m);
Status validate(const OccupancySlice& m);
Status validate(const MapUpdate& m);
Status validate(const VelocityCommand& m);
Status validate(const ServerStatus& m);
Status validate(const KeyframeChunk& m);
Status validate(const ChunkAck& m);

}  // namespace rgbdmap::msg
