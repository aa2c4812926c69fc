// Slices around a robot and the global 2-D map: both one horizontal cut of the tree (grid_cut.hpp).
#include "rgbdmap/map/occupancy_slice.hpp"

#include <cmath>

#include <octomap/OcTree.h>

#include "grid_cut.hpp"
#include "rgbdmap/map/map_config_tables.hpp"

namespace rgbdmap {
namespace {

using SliceResult = Result<msg::OccupancySlice>;

/// The cut of `grid` (its pose, size and resolution set) into its cells.
SliceResult cut(const octomap::OcTree& tree, msg::OccupancySlice grid, const SliceConfig& config) {
  map_detail::GridCut spec;
  spec.T_map_grid = grid.T_map_grid;
  spec.width = grid.width;
  spec.height = grid.height;
  spec.resolution_m = grid.resolution_m;
  spec.z_min_m = grid.z_min_m;
  spec.z_max_m = grid.z_max_m;
  spec.occupied_threshold = config.occupied_threshold;
  const char* error = nullptr;
  grid.cells = map_detail::cutGrid(tree, spec, &error);
  if (error) return SliceResult::failure(std::string("slice: ") + error);
  return grid;
}

}  // namespace

std::string SliceConfig::validate() const {
  std::vector<std::string> problems = sliceConfigTable().problems(*this);
  if (!(size_m >= resolution_m && size_m / resolution_m <= msg::kMaxGridSide))
    problems.push_back("size_m must be >= resolution_m and at most kMaxGridSide cells");
  if (!(z_min_m < z_max_m)) problems.push_back("z_min_m must be < z_max_m");
  if (!(up_in_map.allFinite() && up_in_map.norm() > 1e-9))
    problems.push_back("up_in_map must be a finite non-zero vector");
  return joinProblems(problems);
}

SliceResult extractSlice(const octomap::OcTree& tree, const SE3& T_map_cam, const SliceConfig& config) {
  if (const std::string why = config.validate(); !why.empty())
    return SliceResult::failure("slice config: " + why);
  if (!se3::isValid(T_map_cam, 1e-4))
    return SliceResult::failure("slice: camera pose is not finite or not a rotation");
  const int cells = static_cast<int>(std::lround(config.size_m / config.resolution_m));
  const double size = cells * config.resolution_m;
  msg::OccupancySlice slice;
  slice.T_map_grid.linear() = map_detail::gridAxes(config.up_in_map.normalized());
  const Mat3& R = slice.T_map_grid.linear();
  slice.T_map_grid.translation() = T_map_cam.translation() - 0.5 * size * (R.col(0) + R.col(1));
  slice.resolution_m = static_cast<float>(config.resolution_m);
  slice.width = slice.height = cells;
  slice.z_min_m = static_cast<float>(config.z_min_m);
  slice.z_max_m = static_cast<float>(config.z_max_m);
  return cut(tree, std::move(slice), config);
}

SliceResult extractMapGrid(const octomap::OcTree& tree, double camera_height_m, const SliceConfig& config) {
  if (const std::string why = config.validate(); !why.empty())
    return SliceResult::failure("map grid config: " + why);
  if (!std::isfinite(camera_height_m)) return SliceResult::failure("map grid: camera height is not finite");
  if (tree.size() == 0) return SliceResult::failure("map grid: the tree is empty");
  const Vec3 up = config.up_in_map.normalized();
  const Mat3 R = map_detail::gridAxes(up);
  double x0, y0, z0, x1, y1, z1;
  tree.getMetricMin(x0, y0, z0);
  tree.getMetricMax(x1, y1, z1);
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};  // the box's extent along the grid's x and y
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p((corner & 1) ? x1 : x0, (corner & 2) ? y1 : y0, (corner & 4) ? z1 : z0);
    for (int a = 0; a < 2; ++a) {
      lo[a] = std::min(lo[a], p.dot(R.col(a)));
      hi[a] = std::max(hi[a], p.dot(R.col(a)));
    }
  }
  double res = config.resolution_m;
  const auto sideCells = [&](int a) { return static_cast<int>(std::ceil((hi[a] - lo[a]) / res - 1e-9)); };
  while (std::max(sideCells(0), sideCells(1)) > msg::kMaxGridSide) res *= 2.0;
  msg::OccupancySlice grid;
  grid.T_map_grid.linear() = R;
  grid.T_map_grid.translation() = lo[0] * R.col(0) + lo[1] * R.col(1) + camera_height_m * up;
  grid.resolution_m = static_cast<float>(res);
  grid.width = std::max(1, sideCells(0));
  grid.height = std::max(1, sideCells(1));
  grid.z_min_m = static_cast<float>(config.z_min_m);
  grid.z_max_m = static_cast<float>(config.z_max_m);
  return cut(tree, std::move(grid), config);
}

}  // namespace rgbdmap
