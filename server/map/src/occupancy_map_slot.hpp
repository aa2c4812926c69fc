#pragma once
// One map id's tree with what is needed to swap it safely and to stream its changes.
#include <map>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <utility>
#include <vector>

#include <octomap/OcTree.h>

#include "rgbdmap/map/occupancy_map.hpp"

namespace rgbdmap {

struct OccupancyMap::Slot {
  explicit Slot(int id) : map_id(id) {}
  const int map_id;
  /// Serialises the writers of this tree (an insert's integration, a rebuild's catch-up and swap). Lock
  /// order: write_mutex -> OccupancyMap::mutex_ -> tree_mutex; readers take only mutex_ (briefly), then
  /// tree_mutex shared.
  std::mutex write_mutex;
  mutable std::shared_mutex tree_mutex;   ///< readers shared; applying an update or a swap exclusive
  std::unique_ptr<octomap::OcTree> tree;  ///< nullptr until the first rebuild of a map created by a merge
  uint64_t revision = 0;
  /// Changed leaves (new, or occupied <-> free) since journal_base, listed under the revision that changed
  /// them, so a stream reads only what changed after its consumer's revision (not the whole journal). A
  /// leaf changed again is listed again (6 bytes an entry: measured ~55 bytes an entry with a
  /// hash map of each leaf's latest revision); a stream takes each leaf once. Cleared on a swap or when
  /// its entries outgrow twice the config's cap.
  struct Journal {
    std::map<uint64_t, std::vector<octomap::OcTreeKey>> by_revision;
    size_t entries = 0;  ///< keys listed in by_revision
    void record(std::vector<octomap::OcTreeKey> keys, uint64_t revision) {
      if (keys.empty()) return;
      entries += keys.size();
      by_revision[revision] = std::move(keys);
    }
    void clear() {
      by_revision.clear();
      entries = 0;
    }
    size_t memoryBytes() const { return entries * sizeof(octomap::OcTreeKey) + by_revision.size() * 72; }
  };
  Journal journal;
  uint64_t journal_base = 0;
  /// Keyframe id -> pose it is integrated at in `tree` (guarded by OccupancyMap::mutex_).
  std::map<int64_t, SE3> integrated;
};

}  // namespace rgbdmap
