// The rebuild worker. When few of a dirty map's keyframes moved, only the octree cells their rays touch (at
// the old and the new poses) are recomputed, from every keyframe whose rays reach them, and written into the
// tree under its exclusive lock (rebuildPartly, its steps in partial_rebuild.cpp). Otherwise the tree is
// rebuilt from all kept clouds at the keyframes' current poses without any lock, caught up with keyframes
// inserted meanwhile, then swapped in.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <shared_mutex>
#include <tuple>

#include "cloud_spill.hpp"
#include "occupancy_map_slot.hpp"
#include "partial_rebuild.hpp"
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

// The helpers below take OccupancyMap's entry map as a template parameter `Entries` (its element type is
// private to the class); the caller holds OccupancyMap::mutex_ where they read it.

/// The keyframes of map_id: those integrated in its tree (`integrated`) and those in the map now.
template <class Entries>
detail::PartialKeyframes snapshotKeyframes(const Entries& entries, const std::map<int64_t, SE3>& integrated,
                                           int map_id) {
  detail::PartialKeyframes kfs;
  for (const auto& [id, T] : integrated) {
    const auto& e = entries.at(id);
    detail::PartialKeyframe& k = kfs[id];
    k = {e.order, id, e.cloud, e.box_cam, T, T, true, false, false};
  }
  for (const auto& [id, e] : entries) {
    if (e.map_id != map_id || e.inserting) continue;
    detail::PartialKeyframe& k = kfs[id];
    if (!k.was_in)
      k = {e.order, id, e.cloud, e.box_cam, SE3::Identity(), SE3::Identity(), false, false, false};
    k.is_in = true;
    k.T_new = e.T_map_cam;
  }
  return kfs;
}

/// (insertion order, (keyframe id, pose)) of the keyframes integrated into the tree that the snapshot
/// `kfs` does not know (inserted meanwhile).
using LateKeyframes = std::vector<std::pair<uint64_t, std::pair<int64_t, SE3>>>;
template <class Entries>
LateKeyframes keyframesInsertedMeanwhile(const Entries& entries, const std::map<int64_t, SE3>& integrated,
                                         const detail::PartialKeyframes& kfs) {
  LateKeyframes late;
  for (const auto& [id, T] : integrated)
    if (!kfs.count(id)) late.push_back({entries.at(id).order, {id, T}});
  return late;
}

/// The moved keyframes' new poses (or their leaving) recorded as integrated.
void commitMoves(const detail::PartialKeyframes& kfs, std::map<int64_t, SE3>* integrated) {
  for (const auto& [id, k] : kfs) {
    if (!k.moved) continue;
    if (k.is_in)
      (*integrated)[id] = k.T_new;
    else
      integrated->erase(id);
  }
}

}  // namespace

bool OccupancyMap::rebuildPartly(int map_id) {
  if (!(config_.partial_rebuild_max_fraction > 0.0)) return false;
  const auto t0 = std::chrono::steady_clock::now();
  const double cpu0 = threadCpuMs();
  std::shared_ptr<Slot> slot;
  detail::PartialKeyframes kfs;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = slots_.find(map_id);
    if (it == slots_.end() || !it->second->tree) return false;
    slot = it->second;
    kfs = snapshotKeyframes(entries_, slot->integrated, map_id);
  }
  const size_t moved = detail::markMoved(config_, &kfs);
  if (static_cast<double>(moved) > config_.partial_rebuild_max_fraction * static_cast<double>(kfs.size()))
    return false;

  const octomap::OcTree& geometry = *slot->tree;  // key geometry only (resolution), never its nodes
  const detail::LoadCloud load_cloud = [this](int64_t id, const CloudHandle& handle) {
    return load(id, handle);
  };
  detail::ChangedCells changed;
  size_t cast = 0;
  if (!detail::findChangedCells(kfs, geometry, config_, load_cloud, stop_, &changed, &cast)) return true;
  auto scratch = detail::makeTree(config_);
  if (!detail::recomputeCells(kfs, geometry, config_, load_cloud, stop_, changed, scratch.get(), &cast))
    return true;

  std::lock_guard<std::mutex> write(slot->write_mutex);
  // Keyframes inserted meanwhile are in the tree already; their share of the cells goes into the scratch
  // tree after the others (they came later). A keyframe that moved again meanwhile: the next rebuild.
  LateKeyframes late;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = slots_.find(map_id);
    if (it == slots_.end() || it->second != slot) return true;  // only a rebuild (this thread) drops a slot
    late = keyframesInsertedMeanwhile(entries_, slot->integrated, kfs);
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
    detail::applyWithin(scratch.get(), geometry, *cloud, idT.second, changed.cells, config_.max_range_m);
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
    detail::replaceCells(slot->tree.get(), changed.cells, *scratch);
    slot->revision = revision;
    slot->journal.clear();  // deleted leaves are no change the journal could carry: consumers get it whole
    slot->journal_base = revision;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  commitMoves(kfs, &slot->integrated);
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
    dirty_.erase(std::remove(dirty_.begin(), dirty_.end(), map_id), dirty_.end());
}

void OccupancyMap::rebuildNext() {
  int map_id = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (dirty_.empty()) return;  // its map id was rebuilt (and found clean) by an earlier task
    map_id = dirty_.front();
    dirty_.pop_front();
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
    const auto current = slots_.find(map_id);
    if (current == slots_.end() || current->second != slot) {
      // updatePoses dropped the slot meanwhile (every keyframe merged away): the work goes with it. Keyframes
      // that came back since are in no slot or in a new one, and a rebuild of that is scheduled here.
      ++rebuilds_;
      if (isDirtyLocked(map_id)) markDirtyLocked(map_id);
      return;
    }
    const bool any = std::any_of(entries_.begin(), entries_.end(),
                                 [&](const auto& kv) { return kv.second.map_id == map_id; });
    if (!any) {  // every keyframe left this map (merged away)
      slots_.erase(current);
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
