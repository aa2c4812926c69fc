#pragma once
// Config table (rgbdmap/common/config_table.hpp) of the avoidance rule: keys, ranges and meanings.
// AvoidanceConfig::validate() checks against it.
#include "rgbdmap/client/avoidance.hpp"
#include "rgbdmap/common/config_table.hpp"

namespace rgbdmap {

const ConfigTable<AvoidanceConfig>& avoidanceConfigTable();

}  // namespace rgbdmap
