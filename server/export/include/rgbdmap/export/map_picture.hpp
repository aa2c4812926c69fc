#pragma once
// Top-down picture of the map: what a person looks at first.
//
// Looking down along -up: occupied leaves coloured by height (turbo colour map, blue low, red high, highest
// leaf on top), free space light grey, unknown white; each robot's trajectory (map frame) as a coloured
// polyline with a black (white for dark colours) outline, a filled circle at its start, a legend of robot
// names, a scale bar, a height colour bar with its range, and the map frame's x and y axes. Const access to the tree only (leaf iteration); the tree is not pruned or changed.
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <octomap/OcTree.h>
#include <opencv2/core.hpp>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

struct MapPictureOptions {
  int max_side_px = 1200;          ///< the longer side of the picture (100..10000)
  Vec3 up_in_map = Vec3(0, 0, 1);  ///< the map frame is z-up (north = map y at the top)
  double pixel_m = 0.0;            ///< metres per pixel; 0 = auto (fit the map into max_side_px)
  int margin_px = 40;              ///< free border around the map and trajectories
  /// Occupied leaves outside [min_height_m, max_height_m] (height = p . up, map frame) are not drawn.
  double min_height_m = -std::numeric_limits<double>::infinity();
  double max_height_m = std::numeric_limits<double>::infinity();
  /// Leaves off the top that form a ceiling are not drawn: the highest height bins (one voxel thick) whose
  /// leaves each cover at least this fraction of the occupied footprint are cut away. 0 = keep everything.
  double ceiling_min_cover = 0.3;
  std::array<uint8_t, 3> unknown_rgb{255, 255, 255};
  std::array<uint8_t, 3> free_rgb{225, 225, 225};
  /// Trajectory colours, used in order (wrapping around).
  std::vector<std::array<uint8_t, 3>> trajectory_rgb{{230, 0, 126}, {0, 0, 0},    {255, 130, 0}, {0, 150, 60},
                                                     {120, 0, 200}, {0, 90, 255}, {140, 90, 40}};
  int trajectory_thickness_px = 3;

  /// Empty when every value is in range, else every reason ("; "-separated).
  std::string validate() const;
};

/// Where map points land in the picture.
struct MapPictureLayout {
  Vec3 u_axis = Vec3::UnitX();  ///< map direction of picture +x (right)
  Vec3 v_axis = Vec3::UnitZ();  ///< map direction of picture +y (down)
  double u0 = 0, v0 = 0;  ///< map coordinates (along u_axis, v_axis) of the picture's pixel (0, 0) corner
  double pixel_m = 0.05;
  int width_px = 0, height_px = 0;
  /// Pixel coordinates (x right, y down; pixel centres at integer + 0.5) of a map point.
  cv::Point2d toPixel(const Vec3& p_map) const;
};

using NamedTrajectory = std::pair<std::string, std::vector<SE3>>;  ///< robot name, T_map_cam per pose

/// Renders the picture (CV_8UC3, BGR). layout (optional) receives the projection used. Fails on invalid
/// options, non-finite poses, or nothing to draw (no leaves and no trajectory poses).
Result<cv::Mat> renderMapPicture(const octomap::OcTree& tree,
                                 const std::vector<NamedTrajectory>& trajectories,
                                 const MapPictureOptions& options = {}, MapPictureLayout* layout = nullptr);

/// renderMapPicture, then a PNG at png_path (written beside, then renamed).
Status writeMapPicture(const octomap::OcTree& tree, const std::vector<NamedTrajectory>& trajectories,
                       const std::string& png_path, const MapPictureOptions& options = {});

}  // namespace rgbdmap
