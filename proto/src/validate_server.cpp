// Validation of the server's messages.
#include <cmath>

#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap::msg {
namespace {

Status invalid(const char* reason) { return Status::failure(reason); }

Status validateServerHeader(const Header& h) {
  if (Status s = validate(h); !s) return s;
  if (h.sender != kServerId) return invalid("sender is not the server");
  return Status::success();
}

Status validateToRobot(const Header& h, const std::string& robot_id) {
  if (Status s = validateServerHeader(h); !s) return s;
  if (!isRobotId(robot_id)) return invalid("invalid robot id");
  return Status::success();
}

bool finiteVec(const Vec3& v, double max_abs) { return v.allFinite() && v.cwiseAbs().maxCoeff() <= max_abs; }

}  // namespace

Status validate(const KeyframeAck& m) {
  if (Status s = validateToRobot(m.header, m.robot_id); !s) return s;
  if (m.keyframe_id < 0) return invalid("negative id");
  if (!isValidText(m.reason)) return invalid("invalid reason text");
  return Status::success();
}

Status validate(const PoseCorrections& m) {
  if (Status s = validateToRobot(m.header, m.robot_id); !s) return s;
  if (m.graph_revision < 0) return invalid("negative revision");
  if (!isValidPose(m.T_map_odom)) return invalid("invalid pose");
  if (m.keyframes.size() > static_cast<size_t>(kMaxCorrections)) return invalid("too many keyframes");
  for (const CorrectedPose& k : m.keyframes) {
    if (k.keyframe_id < 0) return invalid("negative id");
    if (!isValidPose(k.T_map_cam)) return invalid("invalid pose");
  }
  return Status::success();
}

Status validate(const LoopEdges& m) {
  if (Status s = validateToRobot(m.header, m.robot_id); !s) return s;
  if (m.graph_revision < 0) return invalid("negative revision");
  if (m.edges.size() > static_cast<size_t>(kMaxLoopEdges)) return invalid("too many loop edges");
  for (const MapLoopEdge& e : m.edges) {
    if (!isRobotId(e.robot_from) || !isRobotId(e.robot_to)) return invalid("invalid robot id");
    if (e.keyframe_from < 0 || e.keyframe_to < 0) return invalid("negative id");
    if (!e.p_from.allFinite() || !e.p_to.allFinite()) return invalid("non-finite position");
  }
  return Status::success();
}

Status validate(const OccupancySlice& m) {
  if (Status s = validateToRobot(m.header, m.robot_id); !s) return s;
  if (!isValidPose(m.T_map_grid)) return invalid("invalid pose");
  if (!(std::isfinite(m.resolution_m) && m.resolution_m > 0.0f && m.resolution_m <= 10.0f))
    return invalid("resolution out of range");
  if (m.width < 1 || m.height < 1 || m.width > kMaxGridSide || m.height > kMaxGridSide)
    return invalid("grid size out of range");
  if (!(std::isfinite(m.z_min_m) && std::isfinite(m.z_max_m) && m.z_min_m < m.z_max_m))
    return invalid("invalid height band");
  if (m.cells.size() != static_cast<size_t>(m.width) * static_cast<size_t>(m.height))
    return invalid("cell count != width * height");
  for (int8_t c : m.cells)
    if (c < -1 || c > 100) return invalid("cell value out of range");
  return Status::success();
}

Status validate(const MapUpdate& m) {
  if (Status s = validateServerHeader(m.header); !s) return s;
  if (m.map_revision < 0) return invalid("negative revision");
  if (!(std::isfinite(m.resolution_m) && m.resolution_m > 0.0 && m.resolution_m <= 10.0))
    return invalid("resolution out of range");
  if (m.raw_size < 0 || m.raw_size > kMaxMapBytes) return invalid("map size out of range");
  if (m.robot_keyframe_id < -1) return invalid("negative keyframe id");
  if (m.compression == MapCompression::kNone && m.data.size() != static_cast<size_t>(m.raw_size))
    return invalid("map data size != raw size");
  if (m.compression == MapCompression::kZstd && m.data.size() > static_cast<size_t>(kMaxMapBytes))
    return invalid("map data too large");
  return Status::success();
}

Status validate(const VelocityCommand& m) {
  // From the server, or from the robot itself (its on-board avoidance commanding its motor controller).
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return invalid("invalid robot id");
  if (m.header.sender != kServerId && m.header.sender != m.robot_id)
    return invalid("sender is neither the server nor the commanded robot");
  if (!finiteVec(m.linear_mps, kMaxSpeed) || !finiteVec(m.angular_radps, kMaxSpeed))
    return invalid("velocity out of range");
  if (!(m.duration_s >= 0.0 && m.duration_s <= kMaxCommandDuration)) return invalid("duration out of range");
  return Status::success();
}

Status validate(const ServerStatus& m) {
  if (Status s = validateServerHeader(m.header); !s) return s;
  if (!isValidText(m.state)) return invalid("invalid state text");
  if (!(std::isfinite(m.uptime_s) && m.uptime_s >= 0.0)) return invalid("invalid uptime");
  if (m.graph_revision < 0 || m.map_revision < 0) return invalid("negative revision");
  if (m.robots.size() > static_cast<size_t>(kMaxRobots)) return invalid("too many robots");
  for (const RobotStatus& r : m.robots) {
    if (!isRobotId(r.robot_id)) return invalid("invalid robot id");
    if (r.keyframes < 0 || r.loop_closures < 0 || r.rejected_messages < 0 || r.last_utime < 0)
      return invalid("negative count");
  }
  if (m.rejects.size() > static_cast<size_t>(kMaxRejectCounts)) return invalid("too many reject counts");
  for (const RejectCount& r : m.rejects) {
    if (!r.robot_id.empty() && !isRobotId(r.robot_id)) return invalid("invalid robot id");
    if (!isValidId(r.reason)) return invalid("invalid reject reason");
    if (r.count < 0) return invalid("negative count");
  }
  return Status::success();
}

}  // namespace rgbdmap::msg
