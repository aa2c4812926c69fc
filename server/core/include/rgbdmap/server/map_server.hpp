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
#include "rgbdmap/intake/intake_stats.hpp"
#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/map/occupancy_map.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/server/map_server_config.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {

struct MapServerStats {
  int keyframes = 0;
  int loops_accepted = 0;  ///< verified by the detector and added to the graph
  int loops_disabled = 0;  ///< currently disabled by the graph's consistency check
  int loop_candidates = 0;
  /// Of them, matched all against all (LoopStats): without a prior pose / after too few matches by
  /// projection.
  int loop_brute_force_no_prior = 0, loop_brute_force_fallback = 0;
  int loop_brute_force_fallback_verified = 0;  ///< of the fallbacks, verified (before the consistency check)
  int loop_fallbacks_skipped = 0;  ///< candidates rejected without it (loop.max_fallbacks_per_keyframe)
  /// Candidates skipped because their features could not be read back from the store (FeatureCache).
  int loop_features_unavailable = 0;
  /// Keyframe features (server.features_in_memory): in RAM, read back from the store, reads that failed.
  size_t features_resident = 0;
  uint64_t features_loads = 0, features_load_failures = 0;
  /// Heap of the loop detector's retrieval index (binary-word posting lists), counted by capacity.
  size_t retrieval_index_bytes = 0;
  /// Freed heap given back to the kernel (server.memory_trim_period_s): trims, RSS they released in all,
  /// their CPU time.
  uint64_t memory_trims = 0;
  int64_t memory_trim_released_bytes = 0;
  double memory_trim_cpu_ms = 0.0;
  std::array<int, kLoopRejectionCount> loops_rejected_by_reason{};
  int optimizations = 0;  ///< optimiser results applied (pose-graph solves and bundle adjustments)
  int graph_solves = 0;   ///< of which with a pose-graph solve
  int graph_solves_skipped =
      0;  ///< loops kept without a solve: the estimate satisfied them (solve_above_chi2)
  int graph_merges_aligned =
      0;  ///< maps joined by a rigid move onto the map they met (solved only if needed)
  /// Neighbourhood solves kept (graph.local_max_nodes): after new loops (counted in graph_solves too) and
  /// placing the weak keyframes after a global BA.
  int graph_solves_local = 0;
  int graph_solves_local_refused =
      0;                          ///< local solves whose answer did not fit (a whole-graph solve followed)
  double last_optimize_ms = 0.0;  ///< of the last pose-graph solve
  BundleAdjustmentStats ba;
  /// Corrections that follow the robots' heartbeats: sent again (the first may have been lost), and
  /// optimisations asked for a robot's last keyframe that no corrections covered yet.
  uint64_t corrections_resent = 0;
  uint64_t optimizations_for_heartbeats = 0;
  int64_t graph_revision = 0;
  int maps = 0;                    ///< connected components of the graph
  uint64_t keyframes_decoded = 0;  ///< keyframes whose images were decoded (passed the headers)
  uint64_t keyframes_decoded_ahead =
      0;  ///< decoded on the decode thread (not the ingest worker); a resend is not
  uint64_t keyframes_features_extracted = 0;  ///< of those, sent without features: extracted here
  uint64_t keyframes_refused = 0;
  int keyframes_waiting = 0;  ///< in the reorder buffer: stored and acknowledged, not in the graph yet
  /// Stored and acknowledged, their loop detection and graph insertion not run yet (the ingest worker
  /// stores and acknowledges new keyframes first): now, and the most at once (how far the map lagged).
  int keyframes_deferred = 0;
  int keyframes_deferred_max = 0;
  /// Per keyframe, from dequeue to the graph update (decode + validate images, features, durable store,
  /// acknowledgement, loop candidates and verification, graph insertion).
  double ingest_ms_median = 0.0, ingest_ms_p90 = 0.0, ingest_ms_max = 0.0;
  double ingest_cpu_ms_median = 0.0, ingest_cpu_ms_p90 = 0.0;  ///< the same in worker-thread CPU time
  double decode_ms_median = 0.0;                               ///< image decoding (validation) and features
  double decode_cpu_ms_median = 0.0;  ///< the same in the decode thread's CPU time (not in ingest_cpu_*)
  double store_ms_median = 0.0;       ///< durable append (fdatasync when store_sync)
  double loops_ms_median = 0.0;       ///< loop detection, graph insertion, loop edges stored
  double verify_ms_median = 0.0;      ///< of which geometric verification of the candidates
  int restored_keyframes = 0, restored_loops = 0;  ///< from the map directory at start
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
  MapStoreRecovery recovery;
  /// The receive side's counters, each filled by its part (rgbdmap/intake/intake_stats.hpp).
  InboxStats inbox;
  HelloHoldStats hello_hold;
  std::vector<ServerRobotStats> robots;  ///< RobotRegistry's, with the placement's figures filled in
  /// The map store now (MapStore::health): failed after an I/O error (a full disk) until a retry
  /// (store_retry_s) recovers it; meanwhile keyframes are left unacknowledged.
  bool store_failed = false;
  std::string store_error;  ///< why it failed ("" when ok)
  uint64_t store_failures = 0, store_recover_attempts = 0, store_recoveries = 0;
  uint64_t keyframes_unacked_store_failed = 0;  ///< keyframe messages (resent ones too) left unacked then
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
