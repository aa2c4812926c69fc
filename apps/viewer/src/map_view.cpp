#include "rgbdmap/viewer/map_view.hpp"

#include <octomap/OcTree.h>

#include <algorithm>
#include <chrono>
#include <sstream>

#include "rgbdmap/map/map_io.hpp"

namespace rgbdmap::viewer {

struct MapView::Robot {
  RobotSnapshot s;
  std::unique_ptr<octomap::OcTree> tree;
};

MapView::MapView(const std::vector<std::string>& robots) : robots_(robots) {
  for (const std::string& r : robots) state_[r] = std::make_unique<Robot>();
}

MapView::~MapView() = default;

MapView::Robot* MapView::find(const std::string& robot) {
  const auto it = state_.find(robot);
  return it == state_.end() ? nullptr : it->second.get();
}

void MapView::changed() {
  ++changes_;
  cv_.notify_all();
}

Status MapView::applyMap(const std::string& robot, const msg::MapUpdate& update) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot* r = find(robot);
  if (!r) return Status::failure("unknown robot " + robot);
  r->s.last_seen_utime = std::max(r->s.last_seen_utime, update.header.utime);
  if (!update.full && update.map_revision <= r->s.map_revision) return Status::success();  // old partial
  if (const Status s = applyMapUpdate(update, &r->tree); !s) {
    ++r->s.map_errors;
    return s;
  }
  r->s.map_revision = update.map_revision;
  r->s.map_utime = update.header.utime;
  if (update.robot_keyframe_id >= 0) r->s.map_keyframe_id = update.robot_keyframe_id;
  r->s.resolution_m = update.resolution_m;
  ++r->s.map_changes;
  changed();
  return Status::success();
}

void MapView::applyCorrections(const std::string& robot, const msg::PoseCorrections& corrections) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot* r = find(robot);
  if (!r) return;
  r->s.last_seen_utime = std::max(r->s.last_seen_utime, corrections.header.utime);
  r->s.keyframes = corrections.keyframes;
  std::sort(
      r->s.keyframes.begin(), r->s.keyframes.end(),
      [](const msg::CorrectedPose& a, const msg::CorrectedPose& b) { return a.keyframe_id < b.keyframe_id; });
  r->s.T_map_odom = corrections.T_map_odom;
  r->s.graph_revision = corrections.graph_revision;
  ++r->s.pose_changes;
  changed();
}

void MapView::applySlice(const std::string& robot, msg::OccupancySlice slice) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot* r = find(robot);
  if (!r) return;
  r->s.last_seen_utime = std::max(r->s.last_seen_utime, slice.header.utime);
  r->s.slice = std::move(slice);
  ++r->s.slice_changes;
  changed();
}

void MapView::applyLoops(const std::string& robot, msg::LoopEdges loops) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot* r = find(robot);
  if (!r) return;
  r->s.last_seen_utime = std::max(r->s.last_seen_utime, loops.header.utime);
  r->s.loops = std::move(loops.edges);
  ++r->s.loop_changes;
  changed();
}

void MapView::applyStatus(const std::string& robot, const msg::ServerStatus& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot* r = find(robot);
  if (!r) return;
  r->s.last_seen_utime = std::max(r->s.last_seen_utime, status.header.utime);
  r->s.server_state = status.state;
  for (const msg::RobotStatus& rs : status.robots)
    if (rs.robot_id == robot) r->s.status = rs;
  ++r->s.status_changes;
  changed();
}

/// A robot's message kept as its newest, unless an older one of the same session (reordered) comes later;
/// a new session (a restarted robot, whose clock may be anywhere) always replaces. True when it was kept.
template <typename T>
bool keepNewest(std::optional<T>* slot, const T& m, int64_t* last_seen_utime) {
  *last_seen_utime = std::max(*last_seen_utime, m.header.utime);
  if (*slot && (*slot)->header.session == m.header.session && (*slot)->header.utime > m.header.utime)
    return false;
  *slot = m;
  return true;
}

void MapView::applyRobotPose(const std::string& robot, const msg::RobotPose& pose) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot* r = find(robot);
  if (!r || !keepNewest(&r->s.live_pose, pose, &r->s.last_seen_utime)) return;
  r->s.live_pose_received_utime = std::chrono::duration_cast<std::chrono::microseconds>(
                                      std::chrono::system_clock::now().time_since_epoch())
                                      .count();
  ++r->s.live_changes;
  changed();
}

void MapView::applyLinkStatus(const std::string& robot, const msg::LinkStatus& link) {
  std::lock_guard<std::mutex> lock(mutex_);
  Robot* r = find(robot);
  if (!r || !keepNewest(&r->s.link, link, &r->s.last_seen_utime)) return;
  ++r->s.status_changes;
  changed();
}

void MapView::countBytes(const std::string& robot, size_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (Robot* r = find(robot)) r->s.bytes_down += bytes;
}

RobotSnapshot MapView::snapshot(const std::string& robot) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = state_.find(robot);
  return it == state_.end() ? RobotSnapshot() : it->second->s;
}

std::vector<Voxel> MapView::occupiedVoxels(const std::string& robot, int64_t* revision) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Voxel> voxels;
  const auto it = state_.find(robot);
  if (revision) *revision = it == state_.end() ? -1 : it->second->s.map_revision;
  if (it == state_.end() || !it->second->tree) return voxels;
  const octomap::OcTree& tree = *it->second->tree;
  const double res = tree.getResolution();
  for (auto leaf = tree.begin_leafs(), end = tree.end_leafs(); leaf != end; ++leaf) {
    if (!tree.isNodeOccupied(*leaf)) continue;
    const octomap::point3d c = leaf.getCoordinate();
    const int n = std::max(1, static_cast<int>(std::lround(leaf.getSize() / res)));
    const double first = -0.5 * leaf.getSize() + 0.5 * res;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k)
          voxels.push_back({static_cast<float>(c.x() + first + i * res),
                            static_cast<float>(c.y() + first + j * res),
                            static_cast<float>(c.z() + first + k * res)});
  }
  return voxels;
}

Result<msg::OccupancySlice> MapView::mapGrid(const std::string& robot, double camera_height_m,
                                             const SliceConfig& config) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = state_.find(robot);
  if (it == state_.end() || !it->second->tree) return Result<msg::OccupancySlice>::failure("no map yet");
  return extractMapGrid(*it->second->tree, camera_height_m, config);
}

Result<std::string> MapView::octomapBinary(const std::string& robot, double* resolution_m,
                                           int64_t* revision) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = state_.find(robot);
  if (it == state_.end() || !it->second->tree) return Result<std::string>::failure("no map yet");
  std::ostringstream out;
  if (!it->second->tree->writeBinaryData(out)) return Result<std::string>::failure("octree not writable");
  *resolution_m = it->second->tree->getResolution();
  *revision = it->second->s.map_revision;
  return out.str();
}

double mapCutHeight(const RobotSnapshot& s) {
  std::vector<double> z;
  for (const msg::CorrectedPose& k : s.keyframes) z.push_back(k.T_map_cam.translation().z());
  if (z.empty()) return s.live_pose ? s.live_pose->T_map_cam.translation().z() : 0.0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

std::optional<SE3> currentPose(const RobotSnapshot& s, int64_t now_utime, bool* live) {
  *live = s.live_pose &&
          1e-6 * static_cast<double>(now_utime - s.live_pose_received_utime) <= kLivePoseMaxAgeS &&
          s.live_pose->graph_revision >= s.graph_revision;
  if (*live) return s.live_pose->T_map_cam;
  if (!s.keyframes.empty()) return s.keyframes.back().T_map_cam;
  return std::nullopt;
}

uint64_t MapView::waitForChange(uint64_t seen, double timeout_s) const {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return changes_ != seen; });
  return changes_;
}

void MapView::notifyAll() {
  std::lock_guard<std::mutex> lock(mutex_);
  changed();
}

}  // namespace rgbdmap::viewer
