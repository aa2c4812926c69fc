#pragma once
// What the viewer knows of each robot, fed by the map streams (MapSubscriber) on the transport's receive
// thread and read by the publisher thread: the robot's copy of its map (octree), its optimised keyframes
// (PoseCorrections), T_map_odom, its latest occupancy slice, loop edges, live pose (the robot's RobotPose)
// and the server's status for it. Every update
// bumps a per-robot change counter and wakes waitForChange(); readers copy what they need under the lock.
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/viewer/foxglove_json.hpp"

namespace octomap {
class OcTree;
}

namespace rgbdmap::viewer {

/// One robot's state as a snapshot (copied out under the lock).
struct RobotSnapshot {
  uint64_t map_changes = 0, pose_changes = 0, slice_changes = 0, status_changes = 0, loop_changes = 0;
  uint64_t live_changes = 0;  ///< RobotPose messages applied
  int64_t map_revision = -1;
  int64_t map_utime = 0;     ///< the server's send time of the newest applied MapUpdate
  int map_keyframe_id = -1;  ///< the robot's newest keyframe in the map (MapUpdate::robot_keyframe_id)
  double resolution_m = 0.05;
  std::vector<msg::CorrectedPose> keyframes;  ///< optimised, in keyframe id order
  SE3 T_map_odom = SE3::Identity();
  int64_t graph_revision = -1;              ///< of the newest PoseCorrections
  std::optional<msg::RobotPose> live_pose;  ///< the robot's newest RobotPose
  int64_t live_pose_received_utime = 0;     ///< this host's clock when it came
  std::optional<msg::OccupancySlice> slice;
  std::vector<msg::MapLoopEdge> loops;  ///< accepted loop edges of the robot's map
  std::optional<msg::RobotStatus> status;
  std::optional<msg::LinkStatus> link;  ///< the robot's newest LinkStatus (its spool and send window)
  std::string server_state;
  uint64_t bytes_down = 0;  ///< server -> robot bytes seen on its channels
  int64_t last_seen_utime = 0;
  uint64_t map_errors = 0;
};

/// A live pose is used while it is at most this old and the robot has applied the newest corrections the
/// viewer has seen; otherwise /R/pose and /tf show the robot's newest optimised keyframe.
constexpr double kLivePoseMaxAgeS = 2.0;
/// The robot's current pose as the viewer shows it: its live pose when fresh (see above), else its newest
/// optimised keyframe; nothing before either. *live tells which.
std::optional<SE3> currentPose(const RobotSnapshot& s, int64_t now_utime, bool* live);

/// The median camera height of the robot's keyframes (its live pose, else 0, before any): the height the
/// global 2-D map is cut at, as the server does.
double mapCutHeight(const RobotSnapshot& s);

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
  /// The robot's live pose; an older one (by the robot's send time) than the newest is ignored.
  void applyRobotPose(const std::string& robot, const msg::RobotPose& pose);
  void applyLinkStatus(const std::string& robot, const msg::LinkStatus& link);
  void countBytes(const std::string& robot, size_t bytes);

  RobotSnapshot snapshot(const std::string& robot) const;
  /// Occupied voxels of the robot's map at the finest resolution (a pruned leaf is expanded into its
  /// voxels, so the count does not depend on how the tree is pruned), and the map revision they are of.
  std::vector<Voxel> occupiedVoxels(const std::string& robot, int64_t* revision) const;

  /// The global 2-D occupancy map of the robot's map (extractMapGrid: the tree's extent, the band of
  /// `config` around `camera_height_m`); fails without a tree.
  Result<msg::OccupancySlice> mapGrid(const std::string& robot, double camera_height_m,
                                      const SliceConfig& config) const;

  /// The robot's map as octomap_msgs/Octomap carries it (OcTree::writeBinaryData: the nodes without the
  /// file header), its resolution and map revision; fails without a tree.
  Result<std::string> octomapBinary(const std::string& robot, double* resolution_m, int64_t* revision) const;

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
