#pragma once
// Octree bytes and files: OctoMap's binary format (.bt: occupied/free per leaf, 2 bits per child) for map
// streams and files, its full format (.ot: log-odds per node) for files. Writing never prunes the tree
// (writeBinaryConst / write on a const tree). Reading treats the bytes as untrusted: the header is parsed
// and the node stream is walked (depth <= 16, exact length, node count = header) before OctoMap sees it.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/map/occupancy_map.hpp"

namespace octomap {
class OcTree;
}
namespace rgbdmap::msg {
struct MapUpdate;
}

namespace rgbdmap {

/// The tree in OctoMap's binary format (what `.bt` files hold); fails when it exceeds msg::kMaxMapBytes.
Result<std::vector<uint8_t>> serializeTree(const octomap::OcTree& tree);
/// Parses binary-format bytes (serializeTree, a .bt file) or full-format bytes (a .ot file of an OcTree).
/// Garbage, truncated or oversized input fails with the reason; never crashes.
Result<std::unique_ptr<octomap::OcTree>> deserializeTree(const std::vector<uint8_t>& bytes);
/// Writes `bt_path` (binary) and `ot_path` (full, with log-odds); an empty path is skipped. Each file is
/// written atomically (writeFileAtomic): on failure the previous file stays whole.
Status writeMapFiles(const octomap::OcTree& tree, const std::string& bt_path, const std::string& ot_path);
/// Reads a .bt or .ot file (recognised by its header) through deserializeTree.
Result<std::unique_ptr<octomap::OcTree>> readMapFile(const std::string& path);

/// Applies a MapStreamChunk's tree to a receiver's copy: full replaces it, partial sets every leaf it
/// carries (resolution must match; a partial needs an existing tree).
Status applyMapChunk(const octomap::OcTree& chunk_tree, bool full, std::unique_ptr<octomap::OcTree>* tree);
/// Fills a MapUpdate (revision, resolution, full flag, zstd-compressed bytes) from a chunk.
Status fillMapUpdate(const MapStreamChunk& chunk, double resolution_m, msg::MapUpdate* update);
/// Reads a MapUpdate back into the receiver's tree (decompression checked, then deserializeTree).
Status applyMapUpdate(const msg::MapUpdate& update, std::unique_ptr<octomap::OcTree>* tree);

/// What `rgbdmap view-map` prints.
struct TreeSummary {
  double resolution_m = 0.0;
  size_t nodes = 0, leaf_nodes = 0, occupied_leaves = 0, free_leaves = 0;
  size_t memory_bytes = 0;                                ///< OcTree::memoryUsage()
  size_t binary_bytes = 0;                                ///< serialised (.bt) size
  double min[3] = {0, 0, 0}, max[3] = {0, 0, 0};          ///< metric bounds of the known cells
  double occupied_volume_m3 = 0.0, free_volume_m3 = 0.0;  ///< summed leaf volumes
};
TreeSummary summarizeTree(const octomap::OcTree& tree);

}  // namespace rgbdmap
