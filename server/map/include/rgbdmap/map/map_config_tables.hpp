#pragma once
// Config tables (rgbdmap/common/config_table.hpp) of the occupancy map and its slices: keys (the server's
// `map:` and `slice:` sections), ranges and meanings. The configs' validate() check against them.
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/map/occupancy_map.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"

namespace rgbdmap {

const ConfigTable<OccupancyMapConfig>& occupancyMapConfigTable();
const ConfigTable<SliceConfig>& sliceConfigTable();

}  // namespace rgbdmap
