#pragma once
// A 2-D occupancy grid around a robot cut from the octree between two heights relative to its camera,
// encoded like ROS nav_msgs/OccupancyGrid (-1 unknown, 0 free, 100 occupied) in msg::OccupancySlice.
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
  /// Heights relative to the camera, along `up_in_map` (map frame = first camera's frame: y points down, so
  /// the default up is (0,-1,0)); the grid is centred on the robot, x = camera forward projected on the
  /// horizontal plane, y = left; T_map_grid = pose of cell (0,0)'s corner, cell (col,row) centre at
  /// T_map_grid * ((col+0.5)*res, (row+0.5)*res, 0).
  double z_min_m = -0.3, z_max_m = 0.3;
  Vec3 up_in_map = Vec3(0, -1, 0);
  double occupied_threshold = 0.5;  ///< occupancy probability above which a leaf counts as occupied

  std::string validate() const;  ///< "" when valid, else all problems "; "-separated
};

/// Each cell samples the tree at its centre at heights z_min_m..z_max_m (one sample per octree leaf size,
/// at least one): occupied if any sample is, else free if any sample is free, else unknown. Const: reads
/// the tree only (no pruning, no expansion). Fails on an invalid config or a non-finite pose. The slice's
/// header and robot_id are left for the caller.
Result<msg::OccupancySlice> extractSlice(const octomap::OcTree& tree, const SE3& T_map_cam,
                                         const SliceConfig& config);

}  // namespace rgbdmap
