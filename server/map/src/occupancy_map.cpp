// OccupancyMap: inserts on the caller's thread, dirty-map bookkeeping, reads and statistics. The rebuild
// worker is in occupancy_rebuild.cpp, streaming in map_stream.cpp.
#include <algorithm>
#include <cmath>
#include <shared_mutex>

#include "cloud_spill.hpp"
#include "occupancy_map_slot.hpp"
#include "scan_update.hpp"

namespace rgbdmap {
namespace {

bool finitePoints(const KeyframeCloud& cloud) {
  for (const Eigen::Vector3f& p : cloud.points_cam)
    if (!p.allFinite()) return false;
  return cloud.colors_rgb.empty() || cloud.colors_rgb.size() == cloud.points_cam.size();
}

}  // namespace

OccupancyMap::OccupancyMap(OccupancyMapConfig config) : config_(std::move(config)) {
  if (!config_.spill_dir.empty() && config_.clouds_in_memory > 0) {
    if (auto spill = detail::CloudSpill::open(config_.spill_dir))
      spill_ = std::move(*spill);
    else
      spill_error_ = spill.error();
  }
  rebuild_worker_.start();
}

OccupancyMap::~OccupancyMap() {
  stop_ = true;
  rebuild_worker_.stop();
}

Status OccupancyMap::insert(KeyframeCloud cloud, int map_id, const SE3& T_map_cam) {
  const int64_t id = cloud.keyframe_id;
  if (!se3::isValid(T_map_cam, 1e-4))
    return Status::failure("keyframe " + std::to_string(id) + ": pose is not finite or not a rotation");
  if (!finitePoints(cloud))
    return Status::failure("keyframe " + std::to_string(id) + ": non-finite points or colours not parallel");
  std::shared_ptr<Slot> slot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (entries_.count(id)) return Status::failure("keyframe " + std::to_string(id) + " already inserted");
    Entry& e = entries_[id];
    e.cloud.cloud = std::make_shared<const KeyframeCloud>(std::move(cloud));
    in_memory_.push_back(id);
    e.map_id = map_id;
    e.T_map_cam = T_map_cam;
    e.order = next_order_++;
    e.box_cam.extend(Eigen::Vector3f::Zero());
    for (const Eigen::Vector3f& p : e.cloud.cloud->points_cam) e.box_cam.extend(p);
    std::shared_ptr<Slot>& s = slots_[map_id];
    if (!s) {
      s = std::make_shared<Slot>(map_id);
      s->tree = detail::makeTree(config_);
    }
    slot = s;
  }
  integrateInserted(id, slot);
  spillOldClouds();
  return Status::success();
}

std::shared_ptr<const KeyframeCloud> OccupancyMap::load(int64_t keyframe_id,
                                                        const CloudHandle& handle) const {
  if (handle.cloud) return handle.cloud;
  if (!spill_ || handle.spill_bytes == 0) {
    ++spill_failures_;
    return nullptr;
  }
  auto cloud = spill_->read({handle.spill_offset, handle.spill_bytes}, keyframe_id);
  if (!cloud) {
    ++spill_failures_;
    return nullptr;
  }
  return std::move(*cloud);
}

void OccupancyMap::spillOldClouds() {
  if (!spill_) return;
  for (;;) {
    int64_t id = 0;
    std::shared_ptr<const KeyframeCloud> cloud;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (in_memory_.size() <= config_.clouds_in_memory) return;
      id = in_memory_.front();
      const Entry& e = entries_.at(id);
      if (e.inserting) return;  // the oldest is still being integrated: later
      in_memory_.pop_front();
      cloud = e.cloud.cloud;
    }
    // Written without the lock; readers meanwhile use the cloud in RAM, which stays until the record is
    // complete. A failed write keeps it in RAM (counted).
    const auto ref = spill_->write(*cloud);
    std::lock_guard<std::mutex> lock(mutex_);
    Entry& e = entries_.at(id);
    if (!ref) {
      ++spill_failures_;
      continue;
    }
    e.cloud.spill_offset = ref->offset;
    e.cloud.spill_bytes = ref->bytes;
    e.cloud.cloud.reset();
  }
}

void OccupancyMap::integrateInserted(int64_t keyframe_id, const std::shared_ptr<Slot>& slot) {
  std::lock_guard<std::mutex> write(slot->write_mutex);
  std::shared_ptr<const KeyframeCloud> cloud;
  SE3 T_map_cam;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Entry& e = entries_.at(keyframe_id);
    auto current = slots_.find(e.map_id);
    // A rebuild's catch-up may have integrated it already, or updatePoses moved it to another map.
    if (slot->integrated.count(keyframe_id) || current == slots_.end() || current->second != slot ||
        !slot->tree) {
      e.inserting = false;
      if (isDirtyLocked(e.map_id)) markDirtyLocked(e.map_id);
      return;
    }
    cloud = e.cloud.cloud;  // in RAM: not spilled while inserting
    T_map_cam = e.T_map_cam;
  }
  const detail::ScanUpdate update =
      detail::computeScanUpdate(*slot->tree, *cloud, T_map_cam, config_.max_range_m);
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    revision = next_revision_++;
  }
  {
    std::unique_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
    std::vector<octomap::OcTreeKey> changed;
    detail::applyScanUpdate(slot->tree.get(), update, &changed);
    slot->journal.record(std::move(changed), revision);
    if (slot->journal.entries > 2 * config_.stream_journal_max_keys) {
      slot->journal.clear();
      slot->journal_base = revision;
    }
    slot->revision = revision;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& e = entries_.at(keyframe_id);
  e.inserting = false;
  slot->integrated[keyframe_id] = T_map_cam;
  // updatePoses may have moved it while it was being integrated.
  if (e.map_id != slot->map_id || !(e.T_map_cam.matrix() == T_map_cam.matrix())) {
    if (isDirtyLocked(slot->map_id)) markDirtyLocked(slot->map_id);
    if (isDirtyLocked(e.map_id)) markDirtyLocked(e.map_id);
  }
}

bool OccupancyMap::isDirtyLocked(int map_id) const {
  const auto slot_it = slots_.find(map_id);
  const std::map<int64_t, SE3>* integrated = slot_it != slots_.end() ? &slot_it->second->integrated : nullptr;
  for (const auto& [id, e] : entries_) {
    if (e.map_id != map_id || e.inserting) continue;
    if (!integrated) return true;
    const auto it = integrated->find(id);
    if (it == integrated->end()) return true;
    const SE3 delta = it->second.inverse() * e.T_map_cam;
    if (delta.translation().norm() > config_.rebuild_translation_m ||
        se3::rotationAngle(delta) > config_.rebuild_rotation_rad)
      return true;
  }
  if (integrated)
    for (const auto& [id, T] : *integrated) {
      const auto it = entries_.find(id);
      if (it == entries_.end() || it->second.map_id != map_id) return true;
    }
  return false;
}

void OccupancyMap::markDirtyLocked(int map_id) {
  if (std::find(dirty_.begin(), dirty_.end(), map_id) != dirty_.end()) return;
  dirty_.push_back(map_id);
  rebuild_worker_.post([this] { rebuildNext(); });
}

void OccupancyMap::dropEmptyMapsLocked(const std::set<int>& touched) {
  std::set<int> empty;
  for (int map_id : touched)
    if (slots_.count(map_id)) empty.insert(map_id);
  for (const auto& [id, e] : entries_) {
    if (empty.empty()) return;
    empty.erase(e.map_id);
  }
  // A rebuild of one of them still running finds its slot gone and drops its work.
  for (int map_id : empty) slots_.erase(map_id);
}

bool OccupancyMap::updatePoses(const std::map<int64_t, std::pair<int, SE3>>& map_id_and_T_map_cam) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::set<int> touched;
  for (const auto& [id, update] : map_id_and_T_map_cam) {
    auto it = entries_.find(id);
    if (it == entries_.end() || !se3::isValid(update.second, 1e-4)) continue;
    touched.insert(it->second.map_id);
    touched.insert(update.first);
    it->second.map_id = update.first;
    it->second.T_map_cam = update.second;
  }
  dropEmptyMapsLocked(touched);
  bool scheduled = false;
  for (int map_id : touched)
    if (isDirtyLocked(map_id)) {
      markDirtyLocked(map_id);
      scheduled = true;
    }
  return scheduled;
}

bool OccupancyMap::waitIdle(double timeout_s) const {
  return rebuild_worker_.waitIdle(timeout_s);  // idle: no task queued, so no map id dirty, none rebuilding
}

bool OccupancyMap::read(int map_id, const std::function<void(const octomap::OcTree&)>& fn) const {
  std::shared_ptr<Slot> slot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = slots_.find(map_id);
    if (it == slots_.end()) return false;
    slot = it->second;
  }
  std::shared_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
  if (!slot->tree) return false;
  fn(*slot->tree);
  return true;
}

std::vector<int> OccupancyMap::mapIds() const {
  std::vector<std::shared_ptr<Slot>> slots;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, slot] : slots_) slots.push_back(slot);
  }
  std::vector<int> ids;
  for (const auto& slot : slots) {
    std::shared_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
    if (slot->tree) ids.push_back(slot->map_id);
  }
  return ids;
}

uint64_t OccupancyMap::revision(int map_id) const {
  std::shared_ptr<Slot> slot;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = slots_.find(map_id);
    if (it == slots_.end()) return 0;
    slot = it->second;
  }
  std::shared_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
  return slot->tree ? slot->revision : 0;
}

std::vector<OccupancyMap::KeptCloud> OccupancyMap::keptClouds() const {
  std::vector<std::pair<int64_t, CloudHandle>> handles;
  std::vector<KeptCloud> out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    handles.reserve(entries_.size());
    out.reserve(entries_.size());
    for (const auto& [id, e] : entries_) {
      handles.emplace_back(id, e.cloud);
      out.push_back({nullptr, e.map_id, e.T_map_cam});
    }
  }
  for (size_t i = 0; i < out.size(); ++i) out[i].cloud = load(handles[i].first, handles[i].second);
  out.erase(std::remove_if(out.begin(), out.end(), [](const KeptCloud& k) { return !k.cloud; }), out.end());
  return out;
}

OccupancyMapStats OccupancyMap::stats() const {
  OccupancyMapStats s;
  std::vector<std::shared_ptr<Slot>> slots;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, slot] : slots_) slots.push_back(slot);
    s.keyframes = entries_.size();
    for (const auto& [id, e] : entries_) {
      if (e.cloud.cloud)
        s.clouds_memory_bytes += e.cloud.cloud->memoryBytes();
      else
        ++s.clouds_spilled;
    }
    s.spill_file_bytes = spill_ ? spill_->bytes() : 0;
    s.spill_failures = spill_failures_.load();
    s.rebuilds = rebuilds_;
    s.partial_rebuilds = partial_rebuilds_;
    s.last_rebuild_keyframes = last_rebuild_keyframes_;
    s.last_rebuild_ms = last_rebuild_ms_;
    s.last_rebuild_cpu_ms = last_rebuild_cpu_ms_;
    s.pending_rebuilds = dirty_.size() + (busy_ ? 1 : 0);
  }
  for (const auto& slot : slots) {
    std::shared_lock<std::shared_mutex> tree_lock(slot->tree_mutex);
    if (!slot->tree) continue;
    ++s.maps;
    s.tree_memory_bytes += slot->tree->memoryUsage();
    s.journal_bytes += slot->journal.memoryBytes();
    for (auto it = slot->tree->begin_leafs(), end = slot->tree->end_leafs(); it != end; ++it) {
      ++s.leaf_nodes;
      if (slot->tree->isNodeOccupied(*it))
        ++s.occupied_leaves;
      else
        ++s.free_leaves;
    }
  }
  return s;
}

}  // namespace rgbdmap
