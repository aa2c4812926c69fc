#pragma once
// An occupancy grid (msg::OccupancySlice: a robot's slice or a map's global 2-D map) as a ROS map_server
// map: a P5 PGM plus its YAML, loadable by map_server / nav2's map_server as it is.
//
// PGM as map_saver writes it: free 254, occupied 0, unknown 205; rows flipped so that the image's top row is
// the grid's last row (row height - 1). Cells are classified with the YAML's thresholds on p = value / 100:
// p >= occupied_thresh (0.65) -> occupied, 0 <= p < free_thresh (0.196) -> free, else (and -1) unknown.
//
// YAML: image (file name relative to the YAML when in the same folder), resolution, origin [x, y, yaw],
// negate 0, occupied_thresh 0.65, free_thresh 0.196, mode trinary; then rgbdmap's own keys that map_server
// ignores: robot_id (a slice's robot; absent for a global map), utime, z_min_m, z_max_m and T_map_grid
// [tx, ty, tz, qx, qy, qz, qw] (the full 3-D pose, so that readSlice gives back exactly what was written).
//
// The map frame is z-up (REP-103), so `origin` is (x, y, yaw) of the grid's cell (0, 0) corner in the map
// frame itself (map_server places pixel (0, height - 1) there); the grids rgbdmap cuts are axis-aligned, so
// yaw is 0, which nav2's static layer requires.
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

/// Writes the PGM and the YAML (each atomically: written beside, then renamed). Fails on an invalid slice
/// (size, cell values, resolution, pose) or an I/O error.
Status writeSlice(const msg::OccupancySlice& slice, const std::string& pgm_path,
                  const std::string& yaml_path);

/// Reads a map_server map back (the YAML, then the PGM it names, relative to the YAML's folder). Cells come
/// back as -1 / 0 / 100 by the YAML's thresholds (negate honoured). T_map_grid, robot_id, utime and the
/// height band come from rgbdmap's keys when present, else from origin (height 0). Rejects a malformed
/// YAML or PGM (magic, size, max value, truncated pixels).
Result<msg::OccupancySlice> readSlice(const std::string& yaml_path);

}  // namespace rgbdmap
