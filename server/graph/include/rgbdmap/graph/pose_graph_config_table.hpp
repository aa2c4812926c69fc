#pragma once
// Config table (rgbdmap/common/config_table.hpp) of the pose graph: keys (the server's `graph:` section),
// ranges and meanings.
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/graph/pose_graph.hpp"

namespace rgbdmap {

const ConfigTable<PoseGraphConfig>& poseGraphConfigTable();

}  // namespace rgbdmap
