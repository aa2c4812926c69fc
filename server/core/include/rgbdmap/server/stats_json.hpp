#pragma once
// The server's statistics as JSON, one key per figure. server_summary.json (rgbdmap-server) is this object;
// report.json's "server" (rgbdmap run) is this object plus the run's evaluation. The keys and their types
// are listed in deploy/schemas/server_stats.schema.json, which the cli tests check both files against.
#include <string>
#include <vector>

#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/server/map_server.hpp"

namespace rgbdmap {

/// Landmarks, observations, local and global bundle adjustments (counts, times), observations rejected.
Json bundleAdjustmentJson(const BundleAdjustmentStats& s);

/// One robot as the server counts it (keyframes stored, sessions, loops, map, fair-share counters).
Json serverRobotStatsJson(const ServerRobotStats& r);

/// Everything the server counts: keyframes, loops, maps, optimisations, bundle adjustment, intake, ingest
/// times, the octree, the store, per robot, rejects, and `merged_maps` (MapServer::mergedMaps: robot ids per
/// map).
Json serverStatsJson(const MapServerStats& s, const std::vector<std::vector<std::string>>& merged_maps);

}  // namespace rgbdmap
