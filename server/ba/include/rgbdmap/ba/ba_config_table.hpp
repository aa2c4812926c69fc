#pragma once
// Config tables (rgbdmap/common/config_table.hpp) of bundle adjustment: keys (the server's `ba:` section),
// ranges and meanings. LandmarkMapConfig::validate() checks against them.
#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/common/config_table.hpp"

namespace rgbdmap {

const ConfigTable<BaSolveConfig>& baSolveConfigTable();
const ConfigTable<LandmarkMapConfig>& landmarkMapConfigTable();

}  // namespace rgbdmap
