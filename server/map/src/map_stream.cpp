// Map stream bytes: a full tree, or only the leaves changed since the consumer's revision; and the
// receiver's side (applying either to its copy), plus the summary `rgbdmap view-map` prints.
#include <algorithm>
#include <optional>
#include <shared_mutex>
#include <tuple>

#include "occupancy_map_slot.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/proto/map_payload.hpp"
#include "scan_update.hpp"

namespace rgbdmap {

Result<MapStreamChunk> OccupancyMap::streamSince(int map_id, uint64_t since) const {
  using R = Result<MapStreamChunk>;
  std::shared_ptr<Slot> slot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = slots_.find(map_id);
    if (it != slots_.end()) slot = it->second;
  }
  if (!slot) return R::failure("no map " + std::to_string(map_id));
  std::shared_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
  if (!slot->tree) return R::failure("no map " + std::to_string(map_id));
  MapStreamChunk chunk;
  chunk.map_id = map_id;
  chunk.revision = slot->revision;
  // The changed leaves first, when the journal covers `since`: the full tree writes two bytes per inner
  // node, so it is at least (nodes - 1) / 4 bytes (nodes = inner + leaves <= 8 * inner + 1); a partial
  // below that is the smaller one without writing the whole tree (O(map), for every robot, every period).
  std::optional<std::vector<uint8_t>> partial_bytes;
  size_t changed = 0;
  if (since != 0 && since >= slot->journal_base && since <= slot->revision) {
    octomap::OcTree partial(slot->tree->getResolution());
    const auto& journal = slot->journal;
    std::vector<octomap::OcTreeKey> keys;
    for (auto it = journal.by_revision.upper_bound(since); it != journal.by_revision.end(); ++it)
      keys.insert(keys.end(), it->second.begin(), it->second.end());
    const auto less = [](const octomap::OcTreeKey& a, const octomap::OcTreeKey& b) {
      return std::tie(a[0], a[1], a[2]) < std::tie(b[0], b[1], b[2]);
    };
    std::sort(keys.begin(), keys.end(), less);  // a leaf changed more than once since: taken once
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    for (const octomap::OcTreeKey& key : keys)
      if (const octomap::OcTreeNode* node = slot->tree->search(key)) {
        partial.setNodeValue(key, node->getLogOdds(), true);
        ++changed;
      }
    if (Result<std::vector<uint8_t>> bytes = serializeTree(partial)) partial_bytes = std::move(*bytes);
    const size_t nodes = slot->tree->size();
    if (partial_bytes && partial_bytes->size() < (nodes > 0 ? (nodes - 1) / 4 : 0)) {
      chunk.full = false;
      chunk.changed_leaves = changed;
      chunk.bytes = std::move(*partial_bytes);
      return chunk;
    }
  }
  Result<std::vector<uint8_t>> full = serializeTree(*slot->tree);
  if (!full) return R::failure(full.error());
  chunk.bytes = std::move(*full);
  if (partial_bytes && partial_bytes->size() < chunk.bytes.size()) {
    chunk.full = false;
    chunk.changed_leaves = changed;
    chunk.bytes = std::move(*partial_bytes);
  }
  return chunk;
}

Status applyMapChunk(const octomap::OcTree& chunk_tree, bool full, std::unique_ptr<octomap::OcTree>* tree) {
  if (full) {
    *tree = std::make_unique<octomap::OcTree>(chunk_tree);
    return Status::success();
  }
  if (!*tree) return Status::failure("partial map update without a full one first");
  if (std::abs((*tree)->getResolution() - chunk_tree.getResolution()) > 1e-9)
    return Status::failure("partial map update has another resolution");
  for (auto it = chunk_tree.begin_leafs(), end = chunk_tree.end_leafs(); it != end; ++it)
    (*tree)->setNodeValue(it.getKey(), it->getLogOdds(), false);
  return Status::success();
}

Status fillMapUpdate(const MapStreamChunk& chunk, double resolution_m, msg::MapUpdate* update) {
  update->map_revision = static_cast<int64_t>(chunk.revision);
  update->resolution_m = resolution_m;
  update->full = chunk.full;
  return msg::setMapBytes(chunk.bytes, msg::MapCompression::kZstd, update);
}

Status applyMapUpdate(const msg::MapUpdate& update, std::unique_ptr<octomap::OcTree>* tree) {
  const Result<msg::Bytes> bytes = msg::mapBytes(update);
  if (!bytes) return Status::failure("map update: " + bytes.error());
  const Result<std::unique_ptr<octomap::OcTree>> chunk = deserializeTree(*bytes);
  if (!chunk) return Status::failure("map update: " + chunk.error());
  return applyMapChunk(**chunk, update.full, tree);
}

TreeSummary summarizeTree(const octomap::OcTree& tree) {
  TreeSummary s;
  s.resolution_m = tree.getResolution();
  s.nodes = tree.size();
  s.memory_bytes = tree.memoryUsage();
  if (const auto bytes = serializeTree(tree)) s.binary_bytes = bytes->size();
  bool first = true;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    ++s.leaf_nodes;
    const double size = it.getSize(), volume = size * size * size;
    const octomap::point3d c = it.getCoordinate();
    for (int a = 0; a < 3; ++a) {
      const double lo = c(a) - size / 2, hi = c(a) + size / 2;
      s.min[a] = first ? lo : std::min(s.min[a], lo);
      s.max[a] = first ? hi : std::max(s.max[a], hi);
    }
    first = false;
    if (tree.isNodeOccupied(*it)) {
      ++s.occupied_leaves;
      s.occupied_volume_m3 += volume;
    } else {
      ++s.free_leaves;
      s.free_volume_m3 += volume;
    }
  }
  return s;
}

}  // namespace rgbdmap
