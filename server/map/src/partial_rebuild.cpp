// A partial rebuild's steps on plain data (see partial_rebuild.hpp). A cell is recomputed whole: every
// keyframe whose rays may reach it contributes, in insertion order, so the result equals a whole rebuild.
#include "partial_rebuild.hpp"

#include <algorithm>
#include <vector>

namespace rgbdmap::detail {
namespace {

/// Octree cells of 2^kCellShift leaves per side (0.4 m at 0.05 m): the unit a partial rebuild recomputes.
constexpr int kCellShift = 3;
constexpr unsigned kCellDepth = 16 - kCellShift;  // their depth in OctoMap's 16-level tree

uint64_t cellOf(const octomap::OcTreeKey& k) {
  return (uint64_t{static_cast<uint16_t>(k[0] >> kCellShift)} << 32) |
         (uint64_t{static_cast<uint16_t>(k[1] >> kCellShift)} << 16) |
         uint64_t{static_cast<uint16_t>(k[2] >> kCellShift)};
}

octomap::OcTreeKey keyOfCell(uint64_t cell) {
  return octomap::OcTreeKey(static_cast<octomap::key_type>(((cell >> 32) & 0xffff) << kCellShift),
                            static_cast<octomap::key_type>(((cell >> 16) & 0xffff) << kCellShift),
                            static_cast<octomap::key_type>((cell & 0xffff) << kCellShift));
}

void addCells(const detail::ScanUpdate& u, CellSet* cells) {
  for (const octomap::OcTreeKey& k : u.free) cells->insert(cellOf(k));
  for (const octomap::OcTreeKey& k : u.occupied) cells->insert(cellOf(k));
}

/// The update restricted to keys in `cells` (order kept: the tree sees the same sequence per leaf).
detail::ScanUpdate restrictTo(const detail::ScanUpdate& u, const CellSet& cells) {
  detail::ScanUpdate out;
  for (const octomap::OcTreeKey& k : u.free)
    if (cells.count(cellOf(k))) out.free.push_back(k);
  for (const octomap::OcTreeKey& k : u.occupied)
    if (cells.count(cellOf(k))) out.occupied.push_back(k);
  return out;
}

/// Whether a keyframe's rays (within its box at T_map_cam, grown by a leaf: rays end at leaf centres) may
/// reach a cell of `cells`, whose cell-index bounds are [lo, hi].
bool mayTouch(const octomap::OcTree& geometry, const Eigen::AlignedBox3f& box_cam, const SE3& T_map_cam,
              const CellSet& cells, const std::array<int, 3>& lo, const std::array<int, 3>& hi) {
  Eigen::AlignedBox3f box;
  const Eigen::Matrix3f R = T_map_cam.linear().cast<float>();
  const Eigen::Vector3f t = T_map_cam.translation().cast<float>();
  for (int c = 0; c < 8; ++c)
    box.extend(R * box_cam.corner(static_cast<Eigen::AlignedBox3f::CornerType>(c)) + t);
  const float grow = static_cast<float>(geometry.getResolution());
  box.min().array() -= grow;
  box.max().array() += grow;
  std::array<int, 3> a{}, b{};
  for (int i = 0; i < 3; ++i) {
    octomap::key_type k0 = 0, k1 = 0;
    if (!geometry.coordToKeyChecked(static_cast<double>(box.min()[i]), k0)) k0 = 0;
    if (!geometry.coordToKeyChecked(static_cast<double>(box.max()[i]), k1)) k1 = 0xffff;
    a[i] = std::max(static_cast<int>(k0 >> kCellShift), lo[i]);
    b[i] = std::min(static_cast<int>(k1 >> kCellShift), hi[i]);
    if (a[i] > b[i]) return false;
  }
  const int64_t n = int64_t{b[0] - a[0] + 1} * (b[1] - a[1] + 1) * (b[2] - a[2] + 1);
  if (n > static_cast<int64_t>(cells.size())) return true;  // cheaper to cast it than to look every cell up
  for (int x = a[0]; x <= b[0]; ++x)
    for (int y = a[1]; y <= b[1]; ++y)
      for (int z = a[2]; z <= b[2]; ++z)
        if (cells.count((uint64_t(x) << 32) | (uint64_t(y) << 16) | uint64_t(z))) return true;
  return false;
}

/// Makes `node` a leaf whose child array is freed: OctoMap frees a node's children only in pruneNode (its
/// deleteNode leaves an empty array behind, and deleting such a node later fails an assertion), so every
/// level is completed to 8 equal leaves and pruned, bottom up. Its value is then meaningless.
void collapseToLeaf(octomap::OcTree* tree, octomap::OcTreeNode* node) {
  for (unsigned i = 0; i < 8; ++i) {
    if (!tree->nodeChildExists(node, i)) {
      tree->createNodeChild(node, i);
      continue;
    }
    octomap::OcTreeNode* child = tree->getNodeChild(node, i);
    if (tree->nodeHasChildren(child)) collapseToLeaf(tree, child);
  }
  for (unsigned i = 0; i < 8; ++i) tree->getNodeChild(node, i)->setLogOdds(0.0f);
  tree->pruneNode(node);
}

/// Removes a cell's subtree (its leaves become unknown) and every ancestor left without children; the
/// ancestors that remain get their occupancy (max of the children) again. The tree keeps the invariant
/// the rest of this file relies on: a node without children has no child array.
void clearCell(octomap::OcTree* tree, uint64_t cell) {
  const octomap::OcTreeKey key = keyOfCell(cell);
  octomap::OcTreeNode* node = tree->getRoot();
  if (!node) return;
  std::vector<std::pair<octomap::OcTreeNode*, unsigned>> path;  // (parent, child index) from the root down
  for (unsigned depth = 0; depth < kCellDepth; ++depth) {
    const unsigned pos = octomap::computeChildIdx(key, static_cast<int>(tree->getTreeDepth() - 1 - depth));
    if (!tree->nodeChildExists(node, pos)) {
      if (depth == 0 || tree->nodeHasChildren(node)) return;  // nothing known there
      tree->expandNode(node);  // a pruned leaf larger than the cell: its other parts keep their value
    }
    path.push_back({node, pos});
    node = tree->getNodeChild(node, pos);
  }
  if (tree->nodeHasChildren(node)) collapseToLeaf(tree, node);
  // Delete upwards while a parent is left without children (never the root).
  size_t level = path.size();
  while (level > 0) {
    auto [parent, pos] = path[level - 1];
    tree->deleteNodeChild(parent, pos);
    --level;
    if (tree->nodeHasChildren(parent) || level == 0) break;
    // parent has an empty child array now: free it (complete and prune), then delete it from its parent
    collapseToLeaf(tree, parent);
  }
  for (size_t l = level; l > 0; --l) path[l - 1].first->updateOccupancyChildren();
}

/// Every leaf of `scratch` written into `tree` at the finest depth (a pruned leaf as all its leaves).
void writeLeaves(octomap::OcTree* tree, const octomap::OcTree& scratch) {
  for (auto it = scratch.begin_leafs(), end = scratch.end_leafs(); it != end; ++it) {
    const float value = it->getLogOdds();
    const unsigned side = 1u << (16 - it.getDepth());
    const octomap::OcTreeKey base = it.getIndexKey();
    for (unsigned x = 0; x < side; ++x)
      for (unsigned y = 0; y < side; ++y)
        for (unsigned z = 0; z < side; ++z)
          tree->setNodeValue(octomap::OcTreeKey(static_cast<octomap::key_type>(base[0] + x),
                                                static_cast<octomap::key_type>(base[1] + y),
                                                static_cast<octomap::key_type>(base[2] + z)),
                             value, false);
  }
}

/// Keeps a moved keyframe's update at its new pose in `changed` while the held total stays within
/// `held_max` bytes.
void holdUpdate(int64_t id, ScanUpdate u, size_t held_max, size_t* held_bytes, ChangedCells* changed) {
  const size_t bytes = (u.free.size() + u.occupied.size()) * sizeof(octomap::OcTreeKey);
  if (*held_bytes + bytes <= held_max) {
    *held_bytes += bytes;
    u.free.shrink_to_fit();  // held for a while: without the vectors' growth slack
    u.occupied.shrink_to_fit();
    changed->at_new.emplace(id, std::move(u));
  }
}

/// The keyframes that contribute to the changed cells, in insertion order: the moved ones in the map and
/// those whose rays may reach a changed cell.
std::vector<const PartialKeyframe*> contributors(const PartialKeyframes& kfs, const octomap::OcTree& geometry,
                                                 const CellSet& cells) {
  const CellBounds bounds = cellBounds(cells);
  std::vector<const PartialKeyframe*> order;
  for (const auto& [id, k] : kfs)
    if (k.is_in && (k.moved || mayTouch(geometry, k.box_cam, k.T_new, cells, bounds.lo, bounds.hi)))
      order.push_back(&k);
  std::sort(order.begin(), order.end(),
            [](const PartialKeyframe* a, const PartialKeyframe* b) { return a->order < b->order; });
  return order;
}

}  // namespace

size_t markMoved(const OccupancyMapConfig& config, PartialKeyframes* kfs) {
  size_t moved = 0;
  for (auto& [id, k] : *kfs) {
    if (k.was_in && k.is_in) {
      const SE3 delta = k.T_old.inverse() * k.T_new;
      k.moved = delta.translation().norm() > config.rebuild_translation_m ||
                se3::rotationAngle(delta) > config.rebuild_rotation_rad;
      if (!k.moved) k.T_new = k.T_old;  // stays where it is integrated
    } else {
      k.moved = true;  // joined or left the map
    }
    moved += k.moved;
  }
  return moved;
}

bool findChangedCells(const PartialKeyframes& kfs, const octomap::OcTree& geometry,
                      const OccupancyMapConfig& config, const LoadCloud& load, const std::atomic<bool>& stop,
                      ChangedCells* changed, size_t* cast) {
  size_t held_bytes = 0;
  const size_t held_max = static_cast<size_t>(config.partial_rebuild_held_mb) << 20;
  for (const auto& [id, k] : kfs) {
    if (!k.moved) continue;
    if (stop) return false;
    const std::shared_ptr<const KeyframeCloud> cloud = load(id, k.cloud);
    if (!cloud) continue;  // unreadable spilled cloud (counted): left as it is
    if (k.was_in) {
      addCells(computeScanUpdate(geometry, *cloud, k.T_old, config.max_range_m), &changed->cells);
      ++*cast;
    }
    if (k.is_in) {
      ScanUpdate u = computeScanUpdate(geometry, *cloud, k.T_new, config.max_range_m);
      addCells(u, &changed->cells);
      holdUpdate(id, std::move(u), held_max, &held_bytes, changed);
      ++*cast;
    }
  }
  return true;
}

CellBounds cellBounds(const CellSet& cells) {
  CellBounds b;
  for (uint64_t c : cells) {
    const int v[3] = {int((c >> 32) & 0xffff), int((c >> 16) & 0xffff), int(c & 0xffff)};
    for (int i = 0; i < 3; ++i) {
      b.lo[i] = std::min(b.lo[i], v[i]);
      b.hi[i] = std::max(b.hi[i], v[i]);
    }
  }
  return b;
}

bool recomputeCells(const PartialKeyframes& kfs, const octomap::OcTree& geometry,
                    const OccupancyMapConfig& config, const LoadCloud& load, const std::atomic<bool>& stop,
                    const ChangedCells& changed, octomap::OcTree* scratch, size_t* cast) {
  for (const PartialKeyframe* k : contributors(kfs, geometry, changed.cells)) {
    if (stop) return false;
    const auto it = changed.at_new.find(k->id);
    if (it != changed.at_new.end()) {
      applyScanUpdate(scratch, restrictTo(it->second, changed.cells));
    } else if (const std::shared_ptr<const KeyframeCloud> cloud = load(k->id, k->cloud)) {
      applyWithin(scratch, geometry, *cloud, k->T_new, changed.cells, config.max_range_m);
      ++*cast;
    }
  }
  return true;
}

void applyWithin(octomap::OcTree* scratch, const octomap::OcTree& geometry, const KeyframeCloud& cloud,
                 const SE3& T_map_cam, const CellSet& cells, double max_range_m) {
  applyScanUpdate(scratch, restrictTo(computeScanUpdate(geometry, cloud, T_map_cam, max_range_m), cells));
}

void replaceCells(octomap::OcTree* tree, const CellSet& cells, const octomap::OcTree& scratch) {
  for (uint64_t c : cells) clearCell(tree, c);
  writeLeaves(tree, scratch);
}

}  // namespace rgbdmap::detail
