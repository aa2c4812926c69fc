#pragma once
// A partial rebuild's work on plain data: which keyframes moved, the octree cells their rays touch at the
// old and the new poses, and those cells recomputed in a scratch tree and written into the map's tree.
// OccupancyMap::rebuildPartly takes the snapshots and the locks around these steps.
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <unordered_set>

#include <octomap/OcTree.h>

#include "rgbdmap/map/occupancy_map.hpp"
#include "scan_update.hpp"

namespace rgbdmap::detail {

/// Octree cells of 2^kCellShift leaves per side (0.4 m at 0.05 m): the unit a partial rebuild recomputes,
/// each named by its three cell indices packed into 16 bits each.
using CellSet = std::unordered_set<uint64_t>;

/// Cell-index bounds [lo, hi] of a CellSet.
struct CellBounds {
  std::array<int, 3> lo{0xffff, 0xffff, 0xffff};
  std::array<int, 3> hi{0, 0, 0};
};

/// A keyframe of the map being partly rebuilt: where it is integrated and where it is now.
struct PartialKeyframe {
  uint64_t order;
  int64_t id;
  OccupancyMap::CloudHandle cloud;
  Eigen::AlignedBox3f box_cam;
  SE3 T_old;  ///< integrated at (valid when was_in)
  SE3 T_new;  ///< current (valid when is_in)
  bool was_in = false, is_in = false, moved = false;
};
using PartialKeyframes = std::map<int64_t, PartialKeyframe>;

/// The cloud in RAM or read back from the spill file (nullptr on a failed read).
using LoadCloud =
    std::function<std::shared_ptr<const KeyframeCloud>(int64_t, const OccupancyMap::CloudHandle&)>;

/// The cells whose leaves change, and the moved keyframes' updates at their new poses that were kept.
struct ChangedCells {
  CellSet cells;
  std::map<int64_t, ScanUpdate> at_new;
};

/// Sets each keyframe's `moved` (beyond the rebuild thresholds, or joined or left the map); an unmoved one
/// keeps the pose it is integrated at. Returns how many moved.
size_t markMoved(const OccupancyMapConfig& config, PartialKeyframes* kfs);

/// The cells the moved keyframes' rays touch where they were and where they are. The updates at the new
/// poses are kept in `changed->at_new` up to partial_rebuild_held_mb; beyond it they are cast again later
/// (CPU instead of memory). `cast` counts the clouds cast. False when `stop` was set (abandoned).
bool findChangedCells(const PartialKeyframes& kfs, const octomap::OcTree& geometry,
                      const OccupancyMapConfig& config, const LoadCloud& load, const std::atomic<bool>& stop,
                      ChangedCells* changed, size_t* cast);

CellBounds cellBounds(const CellSet& cells);

/// The changed cells recomputed into `scratch`, in insertion order, from every keyframe in the map whose
/// rays may reach them: unmoved ones at the poses they are integrated at, moved ones at their new poses.
/// False when `stop` was set (abandoned).
bool recomputeCells(const PartialKeyframes& kfs, const octomap::OcTree& geometry,
                    const OccupancyMapConfig& config, const LoadCloud& load, const std::atomic<bool>& stop,
                    const ChangedCells& changed, octomap::OcTree* scratch, size_t* cast);

/// Integrates the share of `cells` of a cloud at T_map_cam into `scratch`.
void applyWithin(octomap::OcTree* scratch, const octomap::OcTree& geometry, const KeyframeCloud& cloud,
                 const SE3& T_map_cam, const CellSet& cells, double max_range_m);

/// Replaces `cells` of `tree` whole by the leaves of `scratch` (which holds nothing outside them).
void replaceCells(octomap::OcTree* tree, const CellSet& cells, const octomap::OcTree& scratch);

}  // namespace rgbdmap::detail
