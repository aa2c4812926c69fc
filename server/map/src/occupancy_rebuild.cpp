// The rebuild worker: a dirty map id's tree is rebuilt from the kept clouds at the keyframes' current poses
// without any lock, caught up with keyframes inserted meanwhile, then swapped in under the exclusive lock.
#include <algorithm>
#include <chrono>
#include <ctime>
#include <shared_mutex>
#include <tuple>

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
  std::shared_ptr<const KeyframeCloud> cloud;
  SE3 T_map_cam;
};

}  // namespace

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
      detail::applyScanUpdate(
          tree.get(), detail::computeScanUpdate(*tree, *job.cloud, job.T_map_cam, config_.max_range_m));
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
  tree->resetChangeDetection();
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
  slot->integrated = std::move(integrated);
  ++rebuilds_;
  last_rebuild_ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  last_rebuild_cpu_ms_ = threadCpuMs() - cpu0;
  if (isDirtyLocked(map_id))
    markDirtyLocked(map_id);  // moved again meanwhile: one more rebuild (coalesced)
  else
    dirty_.erase(map_id);
}

}  // namespace rgbdmap
