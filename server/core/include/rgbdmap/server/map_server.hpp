#pragma once
// The mapping server: robot sessions, durable keyframe storage, loop closure, one global pose graph and the
// corrections sent back to robots. Transport-agnostic: it is given a Transport (memq://, udpm://, dds://)
// and a KeyStore, and owns three threads:
//   - the transport's receive thread runs onMessage(): authenticate, decode, queue (never blocks);
//   - the ingest worker owns all map state: Hello -> session; Keyframe -> decode + validate images ->
//     store durably -> acknowledge -> loop detection -> pose graph; optimisation results -> apply ->
//     PoseCorrections to every robot;
//   - the map optimiser's worker owns the pose graph and the landmark map: it takes the additions of the
//     ingest worker, solves the pose graph after loops, runs local bundle adjustment after each keyframe
//     and global bundle adjustment after large loops (ingestion never waits for either);
// plus a status thread that publishes ServerStatus.
//
// Identity of a keyframe: (robot, sender session, segment, keyframe id). A robot process that restarts has a
// new session, so its keyframes form new odometry chains of the same robot, re-anchored by loop closure.
// Acknowledgement only after the store returned (fdatasync): a killed server loses no acknowledged
// keyframe. A restart on the same map directory restores robots, keyframes, odometry and loop edges, and
// re-optimises; keyframes a robot re-sends after the restart are recognised and acknowledged again.
#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/backend/bundle_adjustment_stats.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_optimizer.hpp"
#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/intake/intake_stats.hpp"
#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/map/occupancy_map.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/model/map_server_config.hpp"
#include "rgbdmap/model/server_keyframe.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/transport/transport.hpp"
#include "rgbdmap/workers/map_worker.hpp"

namespace rgbdmap {

/// The whole server's counters, each part's filled by that part: the ingest side's (IngestStats), the map
/// worker's (MapWorkerStats), the receive side's (inbox, hello_hold, robots), the optimiser's (ba), the
/// memory trim's and the store's.
struct MapServerStats : IngestStats, MapWorkerStats {
  /// Freed heap given back to the kernel (server.memory_trim_period_s): trims, RSS they released in all,
  /// their CPU time.
  uint64_t memory_trims = 0;
  int64_t memory_trim_released_bytes = 0;
  double memory_trim_cpu_ms = 0.0;
  BundleAdjustmentStats ba;
  /// The receive side's counters, each filled by its part (rgbdmap/intake/intake_stats.hpp).
  InboxStats inbox;
  HelloHoldStats hello_hold;
  std::vector<ServerRobotStats> robots;  ///< RobotRegistry's, with the placement's figures filled in
  /// The map store now (MapStore::health): failed after an I/O error (a full disk) until a retry
  /// (store_retry_s) recovers it; meanwhile keyframes are left unacknowledged.
  bool store_failed = false;
  std::string store_error;  ///< why it failed ("" when ok)
  uint64_t store_failures = 0, store_recover_attempts = 0, store_recoveries = 0;
};

class MapServer {
 public:
  /// `transport` must outlive the server; it may be shared with robots in the same process.
  MapServer(MapServerConfig config, transport::Transport& transport, msg::KeyStore keys);
  ~MapServer();  ///< stop()
  MapServer(const MapServer&) = delete;
  MapServer& operator=(const MapServer&) = delete;

  /// Opens (or creates) the map directory, restores what is stored, subscribes and starts the threads.
  Status start();
  /// Stops the threads promptly; everything acknowledged is already on disk. Idempotent.
  void stop();

  /// Blocks until the ingest queue is empty, every submitted optimisation has been applied and its
  /// corrections published, the map worker has inserted every handed keyframe and no octree rebuild is
  /// pending; false on timeout.
  bool waitIdle(double timeout_s);
  /// Publishes each robot's map stream now if its map changed since the last one (instead of at the next
  /// stream period), and waits (up to timeout_s) until that is done: the final map reaches subscribers
  /// (robots, monitors, viewers) before a run stops. False on timeout.
  bool flushMapStreams(double timeout_s);
  MapServerStats stats() const;
  /// The ServerStatus as the status thread would publish it now (also with server.status_period_s = 0).
  msg::ServerStatus status() const;
  /// Keyframes with their current (optimised) poses, in ingestion order.
  std::vector<ServerKeyframe> keyframes() const;
  /// Loop edges in the order they were found.
  std::vector<ServerLoop> loops() const;
  /// Robot ids grouped by the map they are in now (robots whose newest keyframes share a component).
  std::vector<std::vector<std::string>> mergedMaps() const;
  /// Ingest times (ms per keyframe) so far, in order: all of them up to 4096 keyframes, beyond a uniform
  /// sample of 4096 of them (memory stays bounded however long the server runs).
  std::vector<double> ingestTimesMs() const;

  /// Writes the map's files into out_dir (created if missing): map.bt + map.ot (the tree of the map with the
  /// most keyframes, i.e. the merged one) and map_<id>.bt for every other map, map.ply (coloured VoxelCloud
  /// at 0.02 m from the kept keyframe clouds at their optimised poses), slice_<robot>.pgm/.yaml (each
  /// robot's last slice) and map.png (top view of the main map with its robots' optimised keyframe
  /// trajectories). Const: reads the current trees and clouds. Fails when occupancy is off or empty, or on
  /// an I/O error (the files written so far stay).
  Status writeMapOutputs(const std::string& out_dir) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rgbdmap
