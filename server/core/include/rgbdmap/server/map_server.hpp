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
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_optimizer.hpp"
#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/map/occupancy_map.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/server/map_server_config.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {

struct ServerRobotStats {
  std::string robot_id;
  int keyframes = 0;
  int sessions = 0;     ///< robot processes seen (a restart is a new session)
  int chains = 0;       ///< odometry chains (segments over all sessions)
  int loops = 0;        ///< accepted loop edges touching this robot's keyframes
  int map_id = -1;      ///< graph component of its newest keyframe (first node id of the component)
  bool merged = false;  ///< its newest keyframe shares a component with another robot
  uint64_t bytes_received = 0;
  uint64_t bytes_sent = 0;
  uint64_t keyframes_refused = 0;  ///< acknowledged with accepted = false
  uint64_t duplicates = 0;         ///< re-sent keyframes acknowledged again
  uint64_t out_of_order = 0;       ///< stored before their predecessor was in the graph (they waited)
  uint64_t chain_splits = 0;       ///< keyframes that started a new chain: their predecessor never came
                                   ///< (reorder bound or timeout) or was refused
  uint64_t waiting_for_hello = 0;  ///< keyframes that came before the robot's Hello (held, taken in with it)
  int keyframes_waiting = 0;       ///< stored, acknowledged, waiting for their predecessor now
  /// Fair share: keyframes left unacknowledged because its queue was full, or because it sent
  /// over server.robot_max_keyframes_per_s; refused from the images' headers, before decoding.
  uint64_t queue_full = 0;
  /// Re-sent while the first copy was still in its queue: not queued twice, no slot taken, not demoted.
  uint64_t duplicates_queued = 0;
  uint64_t throttled = 0;
  uint64_t refused_before_decode = 0;
  int keyframes_queued = 0;      ///< in its ingest queue now
  int keyframes_queued_max = 0;  ///< the most it has had queued at once (at most robot_queue_capacity)
  int64_t last_utime = 0;
  std::optional<CameraIntrinsics> camera;
};

/// Bundle adjustment, cumulative: landmark tracks and the local and global adjustments.
struct BundleAdjustmentStats {
  int64_t local_runs = 0, local_failures = 0, global_runs = 0;
  int64_t out_of_time = 0;  ///< adjustments stopped by their wall-clock limit (local or global)
  double local_ms_median = 0.0, local_ms_p90 = 0.0;          ///< wall time of one local BA (its own worker)
  double local_cpu_ms_median = 0.0, local_cpu_ms_p90 = 0.0;  ///< the same in worker-thread CPU time
  double global_ms_last = 0.0, global_ms_max = 0.0;
  double global_cpu_ms_last = 0.0, global_cpu_ms_max = 0.0;
  int global_keyframes_last = 0;  ///< keyframes of the last global BA
  /// Global BAs that ended at their time limit without lowering the error (a map too large for the
  /// observation cap); each doubles the growth its map must reach before the next one (up to 64x).
  int64_t global_fruitless = 0;
  /// Global BAs not run because their map had more than BundleAdjustmentConfig::global_max_keyframes.
  int64_t global_skipped = 0;
  /// Adjustments whose outcome was refused (BundleAdjustmentConfig::max_edge_change_m / _deg): nothing
  /// applied.
  int64_t refused = 0;
  /// Parts of adjustments that no held keyframe observed, put back where they were as a whole
  /// (LandmarkMapConfig::part_link_landmarks), and the largest such correction so far.
  int64_t parts_kept = 0;
  double part_shift_m_max = 0.0;
  int64_t edges_in_tracks = 0;   ///< loop edges whose inlier matches are in the tracks
  int64_t edges_taken_back = 0;  ///< of those, taken out again when the pose graph disabled the edge
  LandmarkStats landmarks;
};

/// The whole server's counters: the ingest part's (IngestStats) and the receive side's, the optimiser's,
/// the map worker's and the store's.
struct MapServerStats : IngestStats {
  /// Freed heap given back to the kernel (server.memory_trim_period_s): trims, RSS they released in all,
  /// their CPU time.
  uint64_t memory_trims = 0;
  int64_t memory_trim_released_bytes = 0;
  double memory_trim_cpu_ms = 0.0;
  BundleAdjustmentStats ba;
  uint64_t messages_rejected = 0;             ///< RejectCounters total (auth, replay, malformed, ...)
  uint64_t keyframes_dropped_queue_full = 0;  ///< all robots' queue_full
  uint64_t keyframes_duplicates_queued = 0;   ///< all robots' duplicates_queued
  uint64_t keyframes_throttled = 0;           ///< all robots' throttled
  uint64_t unknown_robot_messages = 0;
  /// Occupancy map (zero when occupancy_enabled is false).
  size_t map_keyframes = 0;          ///< keyframes inserted into the octree (restored ones included)
  uint64_t map_images_deferred = 0;  ///< queued for the octree without images (read back: memory bound)
  uint64_t map_pose_updates_coalesced = 0;  ///< pose updates replaced by a newer one before they were applied
  size_t map_tree_memory_bytes = 0;         ///< OcTree::memoryUsage() over all maps
  size_t map_journal_bytes = 0;             ///< the map streams' journals of changed leaves
  size_t map_clouds_memory_bytes = 0;       ///< kept keyframe clouds in RAM (for rebuilds and map.ply)
  size_t map_clouds_spilled = 0;            ///< kept clouds in the spill file (map.clouds_in_memory)
  uint64_t map_spill_file_bytes = 0;        ///< its size
  uint64_t map_spill_failures = 0;          ///< spill writes or reads that failed
  size_t map_leaves = 0, map_occupied_leaves = 0;
  uint64_t map_rebuilds = 0;
  double map_last_rebuild_ms = 0.0;
  double map_insert_ms_median = 0.0;  ///< cloud + octree insertion per live keyframe (map worker CPU time)
  double slice_ms_median = 0.0;       ///< slice extraction (map worker CPU time)
  uint64_t slices_sent = 0;
  uint64_t map_updates_sent = 0, map_bytes_sent = 0;  ///< MapUpdate messages and their compressed bytes
  std::vector<ServerRobotStats> robots;
  /// Rejected messages per claimed robot and reason, largest first (robot_id "" = every claimed sender
  /// that is not a known robot); what ServerStatus::rejects carries.
  std::vector<msg::RejectCount> rejects;
  /// The map store now (MapStore::health): failed after an I/O error (a full disk) until a retry
  /// (store_retry_s) recovers it; meanwhile keyframes are left unacknowledged.
  bool store_failed = false;
  std::string store_error;  ///< why it failed ("" when ok)
  uint64_t store_failures = 0, store_recover_attempts = 0, store_recoveries = 0;
};

/// One optimised keyframe as the server holds it.
struct ServerKeyframe {
  int64_t node_id = 0;
  std::string robot_id;
  int64_t session = 0;
  int segment = 0;
  int keyframe_id = 0;
  double timestamp = 0.0;
  int map_id = 0;
  SE3 T_map_kf = SE3::Identity();
  SE3 T_odom_kf = SE3::Identity();
};

/// One loop edge (within a robot or between robots) as the server's pose graph holds it now.
struct ServerLoop {
  int64_t from_node = 0, to_node = 0;  ///< ServerKeyframe::node_id
  SE3 T_from_to = SE3::Identity();
  bool inter_robot = false;
  /// False while the consistency check of the last finished whole-graph solve holds it out (a false match,
  /// or a true one the estimate did not fit then).
  bool enabled = true;
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
