#pragma once
// Stamped pose trajectories and their TUM text format: `timestamp tx ty tz qx qy qz qw` per line.
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

struct StampedPose {
  double timestamp = 0.0;  ///< seconds
  SE3 T_world_cam = SE3::Identity();
};

using Trajectory = std::vector<StampedPose>;

/// Parse TUM trajectory text. Lines starting with '#' and blank lines are skipped. A malformed line
/// (wrong field count, non-numeric, non-finite, zero quaternion) fails with "<source>:<line>: reason".
Result<Trajectory> parseTumTrajectory(const std::string& text, const std::string& source_name = "<text>");
Result<Trajectory> readTumTrajectory(const std::string& path);

/// Format with enough digits to round-trip (timestamps to 1 us, positions to 0.1 um).
std::string formatTumTrajectory(const Trajectory& trajectory);
/// "# header" (when given), the column line and formatTumTrajectory, written atomically (writeFileAtomic).
Status writeTumTrajectory(const std::string& path, const Trajectory& trajectory,
                          const std::string& header_comment = "");

}  // namespace rgbdmap
