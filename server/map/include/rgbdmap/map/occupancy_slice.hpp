#pragma once
// 2-D occupancy grids cut from the octree between two heights, encoded like ROS nav_msgs/OccupancyGrid
// (-1 unknown, 0 free, 100 occupied) in msg::OccupancySlice:
//   - a slice around a robot (8 m x 8 m by default), sent to the robot;
//   - the global 2-D map of a whole map (its tree's extent), written as map_<id>.pgm/.yaml.
// The map frame is z-up (REP-103: the base frame of the first robot's first keyframe), so grids have no yaw:
// x along the map's x, y along its y, heights along up_in_map (default (0, 0, 1)).
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace octomap {
class OcTree;
}

namespace rgbdmap {

struct SliceConfig {
  double size_m = 8.0;         ///< side of the square grid
  double resolution_m = 0.05;  ///< cell side; size_m / resolution_m cells per side (<= msg::kMaxGridSide)
  /// Heights relative to the camera, along `up_in_map`; the grid is centred on the robot, axis-aligned with
  /// the map (x = the map's x projected on the horizontal plane, y = up x x: no yaw); T_map_grid = pose of
  /// cell (0,0)'s corner at camera height, cell (col,row) centre at T_map_grid * ((col+0.5)*res,
  /// (row+0.5)*res, 0).
  double z_min_m = -0.3, z_max_m = 0.3;
  Vec3 up_in_map = Vec3(0, 0, 1);
  double occupied_threshold = 0.5;  ///< occupancy probability above which a leaf counts as occupied

  std::string validate() const;  ///< "" when valid, else all problems "; "-separated
};

/// Each cell samples the tree at its centre at heights z_min_m..z_max_m (one sample per octree leaf size,
/// at least one): occupied if any sample is, else free if any sample is free, else unknown. Const: reads
/// the tree only (no pruning, no expansion). Fails on an invalid config or a non-finite pose. The slice's
/// header and robot_id are left for the caller.
Result<msg::OccupancySlice> extractSlice(const octomap::OcTree& tree, const SE3& T_map_cam,
                                         const SliceConfig& config);

/// The global 2-D map of a whole tree: the same cut as extractSlice over the tree's horizontal extent
/// (every known leaf, rounded out to whole cells), in the band config.z_min_m..z_max_m around
/// `camera_height_m` (the height of the robots' cameras along up, e.g. the median over the map's keyframes),
/// so that it matches the robots' slices. Axis-aligned (no yaw); cell size config.resolution_m, doubled
/// until each side has at most msg::kMaxGridSide cells. config.size_m is not used. robot_id stays empty.
/// Fails on an invalid config, a non-finite height or an empty tree.
Result<msg::OccupancySlice> extractMapGrid(const octomap::OcTree& tree, double camera_height_m,
                                           const SliceConfig& config);

}  // namespace rgbdmap
