#pragma once
// Config tables (rgbdmap/common/config_table.hpp) of the shared vision pipeline: keys, ranges, meanings.
// The robot reads them under odometry.* (deploy/config/odometry.yaml).
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/vision/guided_match_config.hpp"
#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

const ConfigTable<OrbConfig>& orbConfigTable();
const ConfigTable<MatcherConfig>& matcherConfigTable();
const ConfigTable<GuidedMatchConfig>& guidedMatchConfigTable();
const ConfigTable<RansacConfig>& ransacConfigTable();
const ConfigTable<RefineConfig>& refineConfigTable();

}  // namespace rgbdmap
