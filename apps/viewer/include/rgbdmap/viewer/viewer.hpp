#pragma once
// rgbdmap_viewer: the live map viewer behind `rgbdmap-viewer` and `rgbdmap run --viewer`. It subscribes to
// the map streams of the given robots on a Transport (as rgbdmap-monitor does: the server signs each robot's
// copy with that robot's key) and serves them on one HTTP port: the Foxglove WebSocket protocol
// (foxglove.websocket.v1, JSON encoding, public Foxglove schemas) and a built-in three.js page at /.
//
// Topics (per robot R; "map" is the map frame):
//   /R/voxels        foxglove.PointCloud      occupied voxels of R's map, coloured by height (throttled)
//   /R/voxel_delta   rgbdmap.VoxelDelta       the same voxels incrementally: a snapshot, then changes
//   /R/trajectory    foxglove.PosesInFrame    R's optimised keyframes (PoseCorrections)
//   /R/pose          foxglove.PoseInFrame     R's live pose (its RobotPose), else its newest keyframe
//   /R/slice         foxglove.Grid            R's latest occupancy slice
//   /R/map_grid      foxglove.Grid            the global 2-D occupancy map of R's map (as map_<id>.pgm)
//   /R/status        rgbdmap.RobotStatus      keyframes, loops, bandwidth, last seen
//   /R/loops         foxglove.SceneUpdate     accepted loop edges of R's map (LoopEdges), one line list
//   /tf              foxglove.FrameTransforms map -> R (as /R/pose), map -> R_odom (T_map_odom)
// The map frame is z-up (REP-103).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::viewer {

struct ViewerOptions {
  std::vector<std::string> robots;
  bool open = false;  ///< accept unsigned server messages (server in open mode)
  std::string bind = "127.0.0.1";
  int port = 8765;
  std::string web_dir;  ///< index.html + viewer.js (findWebDir())
  std::string three_dir = "/usr/share/javascript/three";
  int max_clients = 16;
  size_t max_queue_bytes = 32u << 20;  ///< per client; beyond it messages to that client are dropped
  double cloud_period_s = 1.0;         ///< at most one PointCloud per robot per period
  double snapshot_period_s = 30.0;     ///< full voxel snapshots to every /R/voxel_delta subscriber
  /// Non-empty: every message published on a channel that is not incremental (all but /R/voxel_delta) also
  /// goes into this MCAP file (schema encoding jsonschema, message encoding json: the Foxglove schemas of
  /// the WebSocket), which appears, synced, when the viewer stops.
  std::string record_path;
};

struct ViewerStats {
  uint64_t clients = 0, connections = 0, messages_sent = 0, bytes_sent = 0, dropped_messages = 0;
  uint64_t malformed = 0, unknown_ops = 0, refused_subscriptions = 0, refused_connections = 0;
  uint64_t map_updates = 0, map_errors = 0, rejected_stream_messages = 0;
  uint64_t voxels = 0;             ///< occupied voxels over all robots' maps, as last published
  uint64_t recorded_messages = 0;  ///< into ViewerOptions::record_path
  bool recording_failed = false;   ///< the recording could not be written or finished (logged)
};

/// The web page's folder (index.html, viewer.js): `web_dir` when given, else share/rgbdmap/viewer found by
/// findDataFile() (beside the executable, RGBDMAP_DATA_DIR, the install prefix); the reason names the places
/// looked in when the page is missing.
Result<std::string> findWebDir(const std::string& web_dir);

class Viewer {
 public:
  /// `server_keys`: robot id -> key (the server's keys file); every robot needs one unless options.open.
  static Result<std::unique_ptr<Viewer>> create(ViewerOptions options, const msg::KeyStore& server_keys);
  ~Viewer();  ///< stop()
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  /// Subscribes the robots' map streams (before or after the transport started).
  Status subscribe(transport::Transport& transport);
  /// Opens the HTTP port and starts publishing.
  Status start();
  /// Closes every client and the port; the subscription handlers do nothing afterwards. Idempotent.
  void stop();
  int port() const;
  ViewerStats stats() const;

  struct Impl;

 private:
  explicit Viewer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rgbdmap::viewer
