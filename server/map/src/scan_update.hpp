#pragma once
// One keyframe cloud turned into the leaf updates of an octree: the discretised endpoints (occupied) and the
// cells their rays cross (free), disjoint, each cell once. Computing it reads only the tree's key geometry
// (resolution), never its nodes, so it runs without the tree's lock; applying it is the only mutation.
#include <memory>
#include <vector>

#include <octomap/OcTree.h>

#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/map/occupancy_map.hpp"

namespace rgbdmap::detail {

struct ScanUpdate {
  std::vector<octomap::OcTreeKey> free;
  std::vector<octomap::OcTreeKey> occupied;
};

/// Endpoints farther than max_range_m from the camera are truncated there: their ray clears free space up to
/// max_range_m and no cell becomes occupied. Points outside the tree's key range are skipped.
ScanUpdate computeScanUpdate(const octomap::OcTree& geometry, const KeyframeCloud& cloud,
                             const SE3& T_map_cam, double max_range_m);
/// Applies the update (occupied after free). `changed` (optional) receives the leaves it created or whose
/// occupancy it flipped (OctoMap's change detection, without its hash set: measured a fifth of the
/// map thread in filling and clearing that set). The tree's own change detection stays off.
void applyScanUpdate(octomap::OcTree* tree, const ScanUpdate& update,
                     std::vector<octomap::OcTreeKey>* changed = nullptr);

/// An empty tree with the config's resolution and sensor model (OctoMap's change detection off).
std::unique_ptr<octomap::OcTree> makeTree(const OccupancyMapConfig& config);

}  // namespace rgbdmap::detail
