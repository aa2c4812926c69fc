#pragma once
// The one horizontal cut of an octree that slices and the global 2-D map share (private to the library).
#include <cstdint>
#include <vector>

#include "rgbdmap/common/se3.hpp"

namespace octomap {
class OcTree;
}

namespace rgbdmap::map_detail {

/// A grid of width x height cells of `resolution_m`; cell (col, row) centre at
/// T_map_grid * ((col + 0.5) * res, (row + 0.5) * res, 0); the band [z_min_m, z_max_m] along the grid's z
/// (= up), relative to the grid's origin.
struct GridCut {
  SE3 T_map_grid = SE3::Identity();
  int width = 0, height = 0;
  double resolution_m = 0.05;
  double z_min_m = -0.3, z_max_m = 0.3;
  double occupied_threshold = 0.5;
};

/// Each cell samples the tree at its centre at heights z_min_m..z_max_m (one sample per octree leaf size,
/// at least one): 100 occupied if any sample is, else 0 free if any sample is free, else -1 unknown. Reads
/// the tree only. Empty on failure (*error says why: a band too large for a tilted up axis).
std::vector<int8_t> cutGrid(const octomap::OcTree& tree, const GridCut& cut, const char** error);

/// Grid axes for `up` (unit): x = map x projected on the plane normal to up (map y when up is along x),
/// y = up x x, z = up. No yaw: a z-up map's grids are axis-aligned.
Mat3 gridAxes(const Vec3& up);

}  // namespace rgbdmap::map_detail
