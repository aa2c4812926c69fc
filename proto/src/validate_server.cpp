// Validation of the server's messages.
#include <cmath>

#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap::msg {
namespace {

Status fail(const char* reason) { return Status::failure(reason); }

Status validateServerHeader(const Header& h) {
  if (Status s = validate(h); !s) return s;
  if (h.sender != kServerId) return fail("sender is not the server");
  return Status::success();
}

Status validateToRobot(const Header& h, const std::string& robot_id) {
  if (Status s = validateServerHeader(h); !s) return s;
  if (!isRobotId(robot_id)) return fail("invalid robot id");
  return Status::success();
}

bool finiteVec(const Vec3& v, double max_abs) { return v.allFinite() && v.cwiseAbs().maxCoeff() <= max_abs; }

}  // namespace

Status validate(const KeyframeAck& m) {
  if (Status s = validateToRobot(m.header, m.robot_id); !s) return s;
  if (m.keyframe_id < 0) return fail("negative id");
  if (!isValidText(m.reason)) return fail("invalid reason text");
  return Status::success();
}

Status validate(const PoseCorrections& m) {
  if (Status s = validateToRobot(m.header, m.robot_id); !s) return s;
  if (m.graph_revision < 0) return fail("negative revision");
  if (!isValidPose(m.T_map_odom)) return fail("invalid pose");
  if (m.keyframes.size() > static_cast<size_t>(kMaxCorrections)) return fail("too many keyframes");
  for (const CorrectedPose& k : m.keyframes) {
    if (k.keyframe_id < 0) return fail("negative id");
    if (!isValidPose(k.T_map_cam)) return fail("invalid pose");
  }
  return Status::success();
}

Status validate(const OccupancySlice& m) {
  if (Status s = validateToRobot(m.header, m.robot_id); !s) return s;
  if (!isValidPose(m.T_map_grid)) return fail("invalid pose");
  if (!(std::isfinite(m.resolution_m) && m.resolution_m > 0.0f && m.resolution_m <= 10.0f))
    return fail("resolution out of range");
  if (m.width < 1 || m.height < 1 || m.width > kMaxGridSide || m.height > kMaxGridSide)
    return fail("grid size out of range");
  if (!(std::isfinite(m.z_min_m) && std::isfinite(m.z_max_m) && m.z_min_m < m.z_max_m))
    return fail("invalid height band");
  if (m.cells.size() != static_cast<size_t>(m.width) * static_cast<size_t>(m.height))
    return fail("cell count != width * height");
  for (int8_t c : m.cells)
    if (c < -1 || c > 100) return fail("cell value out of range");
  return Status::success();
}

Status validate(const MapUpdate& m) {
  if (Status s = validateServerHeader(m.header); !s) return s;
  if (m.map_revision < 0) return fail("negative revision");
  if (!(std::isfinite(m.resolution_m) && m.resolution_m > 0.0 && m.resolution_m <= 10.0))
    return fail("resolution out of range");
  if (m.raw_size < 0 || m.raw_size > kMaxMapBytes) return fail("map size out of range");
  if (m.compression == MapCompression::kNone && m.data.size() != static_cast<size_t>(m.raw_size))
    return fail("map data size != raw size");
  if (m.compression == MapCompression::kZstd && m.data.size() > static_cast<size_t>(kMaxMapBytes))
    return fail("map data too large");
  return Status::success();
}

Status validate(const VelocityCommand& m) {
  // From the server, or from the robot itself (its on-board avoidance commanding its motor controller).
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return fail("invalid robot id");
  if (m.header.sender != kServerId && m.header.sender != m.robot_id)
    return fail("sender is neither the server nor the commanded robot");
  if (!finiteVec(m.linear_mps, kMaxSpeed) || !finiteVec(m.angular_radps, kMaxSpeed))
    return fail("velocity out of range");
  if (!(m.duration_s >= 0.0 && m.duration_s <= kMaxCommandDuration)) return fail("duration out of range");
  return Status::success();
}

Status validate(const ServerStatus& m) {
  if (Status s = validateServerHeader(m.header); !s) return s;
  if (!isValidText(m.state)) return fail("invalid state text");
  if (!(std::isfinite(m.uptime_s) && m.uptime_s >= 0.0)) return fail("invalid uptime");
  if (m.graph_revision < 0 || m.map_revision < 0) return fail("negative revision");
  if (m.robots.size() > static_cast<size_t>(kMaxRobots)) return fail("too many robots");
  for (const RobotStatus& r : m.robots) {
    if (!isRobotId(r.robot_id)) return fail("invalid robot id");
    if (r.keyframes < 0 || r.loop_closures < 0 || r.rejected_messages < 0 || r.last_utime < 0)
      return fail("negative count");
  }
  return Status::success();
}

}  // namespace rgbdmap::msg
