#pragma once
// Parts of the server's statistics as JSON, shared by report.json (`rgbdmap run`) and server_summary.json
// (rgbdmap-server), so both name the same figures the same way.
#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/server/map_server.hpp"

namespace rgbdmap {

/// Landmarks, observations, local and global bundle adjustments (counts, times), observations rejected.
Json bundleAdjustmentJson(const BundleAdjustmentStats& s);

}  // namespace rgbdmap
