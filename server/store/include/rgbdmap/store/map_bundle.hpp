#pragma once
// Map bundles: a whole map directory as one versioned, checksummed file, to move a map to another server
// or site and to archive it. A bundle holds the map store's keyframes (features and images) and loop edges,
// the robots' cameras and mounts (robots.txt) and the octree (map.bt, map.ot) when the directory has them:
// everything a server needs to serve the map. Format: server/store/README.md, "Map bundles".
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::store {

constexpr int kMapBundleFormatVersion = 1;

/// What a bundle holds, read back from it (every entry verified and decoded).
struct MapBundleInfo {
  int format_version = 0;
  int message_schema_version = 0;
  std::string created_utc;  ///< when it was exported, ISO 8601
  std::string source;       ///< the map directory it was exported from
  int64_t keyframes = 0, loops = 0;
  std::map<std::string, int64_t> keyframes_per_robot;
  std::vector<int64_t> sessions;         ///< the robot sessions whose keyframes it holds, ascending
  std::map<std::string, int64_t> files;  ///< carried files (robots.txt, map.bt, map.ot): bytes
  int64_t bundle_bytes = 0;
};

/// Writes the map in `map_dir` (a map store; locked while it is read, so not while a server serves it) to
/// `bundle_path`: a temporary file beside it, synced and renamed. Damaged records the store skips at open
/// are left out (the store logs them). Fails, leaving no file behind, on any error.
Result<MapBundleInfo> exportMapBundle(const std::string& map_dir, const std::string& bundle_path);

/// Verifies the whole bundle (SHA-256 of the file, CRC and decoding of every entry, the counts at its end)
/// and says what it holds. A damaged, truncated or foreign file is an error naming what is wrong.
Result<MapBundleInfo> readMapBundleInfo(const std::string& bundle_path);

/// Creates the map directory `map_dir` from a bundle. `map_dir` must not exist or be empty. The map is
/// built in a temporary folder beside it and renamed into place only once every entry verified, so a
/// damaged or foreign bundle changes nothing.
Result<MapBundleInfo> importMapBundle(const std::string& bundle_path, const std::string& map_dir);

}  // namespace rgbdmap::store
