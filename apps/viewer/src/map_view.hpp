#pragma once
// What the viewer knows of each robot, fed by the map streams (MapSubscriber) on the transport's receive
// thread and read by the publisher thread: the robot's copy of its map (octree), its optimised keyframes
// (PoseCorrections), T_map_odom, its latest occupancy slice and the server's status for it. Every update
// bumps a per-robot change counter and wakes waitForChange(); readers copy what they need under the lock.
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "foxglove_json.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace octomap {
class OcTree;
}

namespace rgbdmap::viewer {

/// One robot's state as a snapshot (copied out under the lock).
struct RobotSnapshot {
  uint64_t map_changes = 0, pose_changes = 0, slice_changes = 0, status_changes = 0, loop_changes = 0;
  int64_t map_revision = -1;
  int64_t map_utime = 0;  ///< the server's send time of the newest applied MapUpdate
  double resolution_m = 0.05;
  std::vector<msg::CorrectedPose> keyframes;  ///< optimised, in keyframe id order
  SE3 T_map_odom = SE3::Identity();
  std::optional<msg::OccupancySlice> slice;
  std::vector<msg::MapLoopEdge> loops;  ///< accepted loop edges of the robot's map
  std::optional<msg::RobotStatus> status;
  std::string server_state;
  uint64_t bytes_down = 0;  ///< server -> robot bytes seen on its channels
  int64_t last_seen_utime = 0;
  uint64_t map_errors = 0;
};

class MapView {
 public:
  explicit MapView(const std::vector<std::string>& robots);
  ~MapView();

  const std::vector<std::string>& robots() const { return robots_; }

  Status applyMap(const std::string& robot, const msg::MapUpdate& update);
  void applyCorrections(const std::string& robot, const msg::PoseCorrections& corrections);
  void applySlice(const std::string& robot, msg::OccupancySlice slice);
  void applyLoops(const std::string& robot, msg::LoopEdges loops);
  void applyStatus(const std::string& robot, const msg::ServerStatus& status);
  void countBytes(const std::string& robot, size_t bytes);

  RobotSnapshot snapshot(const std::string& robot) const;
  /// Occupied voxels of the robot's map at the finest resolution (a pruned leaf is expanded into its
  /// voxels, so the count does not depend on how the tree is pruned), and the map revision they are of.
  std::vector<Voxel> occupiedVoxels(const std::string& robot, int64_t* revision) const;

  /// Waits until something changed since `seen` (the sum of every change counter) or the timeout; returns it.
  uint64_t waitForChange(uint64_t seen, double timeout_s) const;
  /// Wakes waitForChange() (to stop).
  void notifyAll();

 private:
  struct Robot;
  Robot* find(const std::string& robot);
  void changed();

  std::vector<std::string> robots_;
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::map<std::string, std::unique_ptr<Robot>> state_;
  uint64_t changes_ = 0;
};

}  // namespace rgbdmap::viewer
