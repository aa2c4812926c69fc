// The rebuild worker. When few of a dirty map's keyframes moved, only the octree cells their rays touch (at
// the old and the new poses) are recomputed, from every keyframe whose rays reach them, and written into the
// tree under its exclusive lock (rebuildPartly). Otherwise the tree is rebuilt from all kept clouds at the
// keyframes' current poses without any lock, caught up with keyframes inserted meanwhile, then swapped in.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <shared_mutex>
#include <tuple>
#include <unordered_set>

#include "cloud_spill.hpp"
#include "occupancy_map_slot.hpp"
#include "scan_update.hpp"

namespace rgbdmap {
namespace {

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

struct Job {
  uint64_t order;
  int64_t keyframe_id;
  OccupancyMap::CloudHandle cloud;
  SE3 T_map_cam;
};

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

using CellSet = std::unordered_set<uint64_t>;

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

}  // namespace

bool OccupancyMap::rebuildPartly(int map_id) {
  if (!(config_.partial_rebuild_max_fraction > 0.0)) return false;
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = threadCpuMs();
  struct Kf {
    uint64_t order;
    int64_t id;
    CloudHandle cloud;
    Eigen::AlignedBox3f box_cam;
    SE3 T_old;  ///< integrated at (valid when was_in)
    SE3 T_new;  ///< current (valid when is_in)
    bool was_in = false, is_in = false, moved = false;
  };
  std::shared_ptr<Slot> slot;
  std::map<int64_t, Kf> kfs;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = slots_.find(map_id);
    if (it == slots_.end() || !it->second->tree) return false;
    slot = it->second;
    for (const auto& [id, T] : slot->integrated) {
      const Entry& e = entries_.at(id);
      Kf& k = kfs[id];
      k = {e.order, id, e.cloud, e.box_cam, T, T, true, false, false};
    }
    for (const auto& [id, e] : entries_) {
      if (e.map_id != map_id || e.inserting) continue;
      Kf& k = kfs[id];
      if (!k.was_in)
        k = {e.order, id, e.cloud, e.box_cam, SE3::Identity(), SE3::Identity(), false, false, false};
      k.is_in = true;
      k.T_new = e.T_map_cam;
    }
  }
  size_t moved = 0;
  for (auto& [id, k] : kfs) {
    if (k.was_in && k.is_in) {
      const SE3 delta = k.T_old.inverse() * k.T_new;
      k.moved = delta.translation().norm() > config_.rebuild_translation_m ||
                se3::rotationAngle(delta) > config_.rebuild_rotation_rad;
      if (!k.moved) k.T_new = k.T_old;  // stays where it is integrated
    } else {
      k.moved = true;  // joined or left the map
    }
    moved += k.moved;
  }
  if (static_cast<double>(moved) > config_.partial_rebuild_max_fraction * static_cast<double>(kfs.size()))
    return false;

  // The cells whose leaves change: those the moved keyframes' rays touch where they were and where they are.
  const octomap::OcTree& geometry = *slot->tree;  // key geometry only (resolution), never its nodes
  CellSet cells;
  // The moved keyframes' updates at their new poses are kept for the second pass up to
  // partial_rebuild_held_mb; beyond it they are cast again there (CPU instead of memory).
  std::map<int64_t, detail::ScanUpdate> at_new;
  size_t held_bytes = 0;
  const size_t held_max = static_cast<size_t>(config_.partial_rebuild_held_mb) << 20;
  size_t cast = 0;
  for (const auto& [id, k] : kfs) {
    if (!k.moved) continue;
    if (stop_) return true;
    const std::shared_ptr<const KeyframeCloud> cloud = load(id, k.cloud);
    if (!cloud) continue;  // unreadable spilled cloud (counted): left as it is
    if (k.was_in) {
      addCells(detail::computeScanUpdate(geometry, *cloud, k.T_old, config_.max_range_m), &cells);
      ++cast;
    }
    if (k.is_in) {
      detail::ScanUpdate u = detail::computeScanUpdate(geometry, *cloud, k.T_new, config_.max_range_m);
      addCells(u, &cells);
      const size_t bytes = (u.free.size() + u.occupied.size()) * sizeof(octomap::OcTreeKey);
      if (held_bytes + bytes <= held_max) {
        held_bytes += bytes;
        u.free.shrink_to_fit();  // held for a while: without the vectors' growth slack
        u.occupied.shrink_to_fit();
        at_new.emplace(id, std::move(u));
      }
      ++cast;
    }
  }
  std::array<int, 3> lo{0xffff, 0xffff, 0xffff}, hi{0, 0, 0};
  for (uint64_t c : cells) {
    const int v[3] = {int((c >> 32) & 0xffff), int((c >> 16) & 0xffff), int(c & 0xffff)};
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], v[i]);
      hi[i] = std::max(hi[i], v[i]);
    }
  }

  // Those cells recomputed in a scratch tree, in insertion order, from every keyframe in the map whose rays
  // may reach them: unmoved ones at the poses they are integrated at, moved ones at their new poses.
  std::vector<const Kf*> order;
  for (const auto& [id, k] : kfs)
    if (k.is_in && (k.moved || mayTouch(geometry, k.box_cam, k.T_new, cells, lo, hi))) order.push_back(&k);
  std::sort(order.begin(), order.end(), [](const Kf* a, const Kf* b) { return a->order < b->order; });
  auto scratch = detail::makeTree(config_);
  for (const Kf* k : order) {
    if (stop_) return true;
    const auto it = at_new.find(k->id);
    if (it != at_new.end()) {
      detail::applyScanUpdate(scratch.get(), restrictTo(it->second, cells));
    } else if (const std::shared_ptr<const KeyframeCloud> cloud = load(k->id, k->cloud)) {
      detail::applyScanUpdate(
          scratch.get(),
          restrictTo(detail::computeScanUpdate(geometry, *cloud, k->T_new, config_.max_range_m), cells));
      ++cast;
    }
  }

  std::lock_guard<std::mutex> write(slot->write_mutex);
  // Keyframes inserted meanwhile are in the tree already; their share of the cells goes into the scratch
  // tree after the others (they came later). A keyframe that moved again meanwhile: the next rebuild.
  std::vector<std::pair<uint64_t, std::pair<int64_t, SE3>>> late;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = slots_.find(map_id);
    if (it == slots_.end() || it->second != slot) return true;  // only a rebuild (this thread) drops a slot
    for (const auto& [id, T] : slot->integrated)
      if (!kfs.count(id)) late.push_back({entries_.at(id).order, {id, T}});
  }
  std::sort(late.begin(), late.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [order_, idT] : late) {
    CloudHandle handle;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      handle = entries_.at(idT.first).cloud;
    }
    const std::shared_ptr<const KeyframeCloud> cloud = load(idT.first, handle);
    if (!cloud) continue;
    detail::applyScanUpdate(
        scratch.get(),
        restrictTo(detail::computeScanUpdate(geometry, *cloud, idT.second, config_.max_range_m), cells));
    ++cast;
  }
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    revision = next_revision_++;
  }
  {
    // The cells are replaced whole: readers see the tree before or after, never between.
    std::unique_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
    octomap::OcTree* tree = slot->tree.get();
    for (uint64_t c : cells) clearCell(tree, c);
    for (auto it = scratch->begin_leafs(), end = scratch->end_leafs(); it != end; ++it) {
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
    slot->revision = revision;
    slot->journal.clear();  // deleted leaves are no change the journal could carry: consumers get it whole
    slot->journal_base = revision;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, k] : kfs) {
    if (!k.moved) continue;
    if (k.is_in)
      slot->integrated[id] = k.T_new;
    else
      slot->integrated.erase(id);
  }
  ++partial_rebuilds_;
  finishRebuildLocked(map_id, cast, t0, cpu0);
  return true;
}

void OccupancyMap::finishRebuildLocked(int map_id, size_t keyframes_cast,
                                       std::chrono::steady_clock::time_point t0, double cpu0) {
  ++rebuilds_;
  last_rebuild_keyframes_ = keyframes_cast;
  last_rebuild_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  last_rebuild_cpu_ms_ = threadCpuMs() - cpu0;
  if (isDirtyLocked(map_id))
    markDirtyLocked(map_id);  // moved again meanwhile: one more rebuild (coalesced)
  else
    dirty_.erase(map_id);
}

void OccupancyMap::rebuildNext() {
  int map_id = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (dirty_.empty()) return;  // its map id was rebuilt (and found clean) by an earlier task
    map_id = *dirty_.begin();
    dirty_.erase(dirty_.begin());
    busy_ = true;
  }
  rebuild(map_id);
  std::lock_guard<std::mutex> lock(mutex_);
  busy_ = false;
}

void OccupancyMap::rebuild(int map_id) {
  if (rebuildPartly(map_id)) return;
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = threadCpuMs();
  // Entries of map_id that are integrated somewhere (an insert in progress integrates itself afterwards).
  const auto collect = [&](const std::set<int64_t>& skip) {
    std::vector<Job> jobs;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, e] : entries_)
      if (e.map_id == map_id && !e.inserting && !skip.count(id))
        jobs.push_back({e.order, id, e.cloud, e.T_map_cam});
    std::sort(jobs.begin(), jobs.end(), [](const Job& a, const Job& b) { return a.order < b.order; });
    return jobs;
  };
  std::map<int64_t, SE3> integrated;
  auto tree = detail::makeTree(config_);
  const auto integrate = [&](const std::vector<Job>& jobs) {
    for (const Job& job : jobs) {
      if (stop_) return false;
      // A spilled cloud that cannot be read back is left out (counted) but recorded as integrated: the map
      // goes on without it rather than rebuilding forever.
      if (const std::shared_ptr<const KeyframeCloud> cloud = load(job.keyframe_id, job.cloud))
        detail::applyScanUpdate(tree.get(),
                                detail::computeScanUpdate(*tree, *cloud, job.T_map_cam, config_.max_range_m));
      integrated[job.keyframe_id] = job.T_map_cam;
    }
    return true;
  };
  if (!integrate(collect({}))) return;

  std::shared_ptr<Slot> slot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::shared_ptr<Slot>& s = slots_[map_id];
    if (!s) s = std::make_shared<Slot>(map_id);  // a new map id (a merge target): no tree until the swap
    slot = s;
  }
  std::lock_guard<std::mutex> write(slot->write_mutex);
  std::set<int64_t> done;
  for (const auto& [id, T] : integrated) done.insert(id);
  if (!integrate(collect(done))) return;  // keyframes inserted during the build
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool any = std::any_of(entries_.begin(), entries_.end(),
                                 [&](const auto& kv) { return kv.second.map_id == map_id; });
    if (!any && slots_[map_id] == slot) {  // every keyframe left this map (merged away)
      slots_.erase(map_id);
      ++rebuilds_;
      return;
    }
    revision = next_revision_++;
  }
  {
    std::unique_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
    slot->tree.swap(tree);
    slot->revision = revision;
    slot->journal.clear();
    slot->journal_base = revision;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  const size_t cast = integrated.size();
  slot->integrated = std::move(integrated);
  finishRebuildLocked(map_id, cast, t0, cpu0);
}

}  // namespace rgbdmap
