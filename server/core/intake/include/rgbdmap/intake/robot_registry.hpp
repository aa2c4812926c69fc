#pragma once
// The robots a server knows: index (order of first Hello, persisted), camera, current session and counters.
// Thread-safe (one internal mutex): the receive thread counts bytes, the worker registers and counts.
// Cameras and camera mounts are persisted in <map_dir>/robots.txt (written to a temporary file, synced, then
// renamed), so a restarted server can rebuild the features of stored keyframes before any robot says Hello
// again.
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/intake/intake_stats.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

class RobotRegistry {
 public:
  /// Registers a Hello. Returns true when something to persist changed (new robot, camera or camera mount).
  /// `localize`: the robot localises in the map without changing it; its camera and mount are used for its
  /// keyframes but never persisted (robots.txt keeps what a mapping Hello or the file said), and nothing
  /// to persist changes.
  Result<bool> hello(const std::string& robot_id, int64_t session, const CameraIntrinsics& camera,
                     const SE3& T_base_camera = defaultT_base_camera(), bool localize = false);
  /// The robot's newest Hello asked to localise (or the server put it in localize mode).
  bool localizing(const std::string& robot_id) const;
  /// A keyframe of `session` from a known robot: a newer session than the registry's becomes the current
  /// one (counted like a Hello's). After a restart the registry comes back without sessions and a robot
  /// that heard the old server does not say Hello again (LCM has no durable Hello): without this its
  /// keyframes would never be in the PoseCorrections, which cover the current session only.
  void noteSession(const std::string& robot_id, int64_t session);
  Status save(const std::string& map_dir) const;
  /// Reads robots.txt if present (a missing file is an empty registry).
  Status load(const std::string& map_dir);

  int index(const std::string& robot_id) const;  ///< -1 before its first Hello
  std::optional<CameraIntrinsics> camera(const std::string& robot_id) const;
  /// The robot's camera mount (its Hello's T_base_camera; the default mount for a robot not heard of): a new
  /// chain of the robot starts at T_map_kf = T_base_camera * T_odom_kf, so maps are z-up.
  SE3 mount(const std::string& robot_id) const;
  int64_t currentSession(const std::string& robot_id) const;

  void addBytesReceived(const std::string& robot_id, size_t bytes, int64_t utime);
  void addBytesSent(const std::string& robot_id, size_t bytes);
  /// What became of one keyframe message of a robot, each counted in its own ServerRobotStats field.
  enum class KeyframeOutcome {
    kPlaced,               ///< in the graph (keyframes)
    kDuplicate,            ///< seen before, acknowledged again (duplicates)
    kRefused,              ///< acknowledged with accepted = false (keyframes_refused)
    kRefusedBeforeDecode,  ///< its image headers refused it (refused_before_decode; kRefused follows)
    kOutOfOrder,           ///< stored before its predecessor was in the graph (out_of_order)
    kChainSplit,           ///< started a new chain: its predecessor never came or was refused (chain_splits)
    kWaitingForHello,      ///< came before the robot's Hello (waiting_for_hello)
    kQueueFull,            ///< its robot's queue had no room (queue_full)
    kDuplicateQueued,      ///< a copy is still queued (duplicates_queued)
    kThrottled,            ///< over its robot's rate (throttled)
  };
  void recordKeyframe(const std::string& robot_id, KeyframeOutcome outcome);
  /// An accepted loop edge touching a keyframe of the robot.
  void countLoop(const std::string& robot_id);

  /// A robot's newest Heartbeat: the keyframe it sent last, when it was heard, and since when it has been
  /// naming that keyframe (a robot that stopped sending keeps naming its last one).
  struct HeartbeatSeen {
    int64_t session = 0;
    int segment = 0;
    int last_keyframe_id = -1;
    std::chrono::steady_clock::time_point heard, naming_since;
  };
  /// Robots that said Hello only (the receive thread; the count of entries stays bounded by the Hellos).
  void noteHeartbeat(const msg::Heartbeat& heartbeat, std::chrono::steady_clock::time_point now);
  std::map<std::string, HeartbeatSeen> heartbeats() const;

  /// Robots that said Hello, in index order.
  std::vector<ServerRobotStats> stats() const;

 private:
  struct Entry {
    ServerRobotStats stats;
    int index = -1;
    int64_t session = 0;
    SE3 T_base_camera = defaultT_base_camera();
    bool localize = false;
    /// What robots.txt holds for it (from the file or a mapping Hello); unset: nothing to persist.
    std::optional<std::pair<CameraIntrinsics, SE3>> persisted;
    std::optional<HeartbeatSeen> heartbeat;
  };
  Entry& entry(const std::string& robot_id);  // caller holds mutex_

  mutable std::mutex mutex_;
  std::map<std::string, Entry> robots_;
  int next_index_ = 0;
};

}  // namespace rgbdmap
