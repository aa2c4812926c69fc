#pragma once
// Configuration of the mapping server (MapServer): plain struct with documented defaults. rgbdmap-server and
// `rgbdmap run` read it from YAML (server_config.hpp); every key is documented in deploy/config/server.yaml.
#include <cstddef>
#include <string>
#include <vector>

#include "rgbdmap/backend/bundle_adjustment_config.hpp"
#include "rgbdmap/backend/edge_information.hpp"
#include "rgbdmap/backend/placement.hpp"
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/map/occupancy_map.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

struct MapServerConfig {
  std::string map_dir = "map";  ///< durable keyframes, loop edges and robot cameras
  /// Robots whose channels are subscribed at start. With an empty list and an LCM transport, the server
  /// subscribes "rgbdmap/*" and serves any robot the KeyStore admits (DDS needs the list).
  std::vector<std::string> robots;
  bool store_sync = true;        ///< fdatasync each keyframe before acknowledging it
  double status_period_s = 1.0;  ///< ServerStatus to every known robot; 0 turns it off
  /// LoopEdges (for visualisers) after each optimisation: the newest this many enabled loop edges of the
  /// robot's map, per robot. The whole map's would grow with it: 50,000 loops were 4 MB per robot and result.
  int loop_edges_max = 2000;
  /// Fair share: each robot's keyframes wait in a queue of their own, served round-robin with
  /// the other robots'; a keyframe that does not fit its robot's queue (robot_queue_capacity keyframes,
  /// robot_queue_bytes encoded bytes) or the total (ingest_queue_capacity, all robots together) is left
  /// unacknowledged (the robot resends it) and counted as queue_full.
  size_t ingest_queue_capacity = 1024;
  size_t robot_queue_capacity = 64;
  size_t robot_queue_bytes = 64u << 20;
  /// Per-robot token bucket over keyframe messages (retransmissions included), checked before decoding:
  /// beyond it a keyframe is left unacknowledged and counted as throttled. 0 turns it off. The burst
  /// covers a whole client send window (client max_pending, 256) retransmitted at once after an outage.
  double robot_max_keyframes_per_s = 30.0;
  double robot_keyframe_burst = 256.0;
  /// The optimiser and octree-rebuild threads run this much nicer than the server (Linux nice, per
  /// thread): under overload decode, ingest (storage, acknowledgements) and the map worker (slices) get the
  /// cores first, and optimisation and rebuilds batch what queued meanwhile. 0: all threads equal.
  int background_nice = 5;
  /// The features of this many keyframes (the most recently used; ~85 KB each at 1,000 features) stay in
  /// RAM for loop closure and bundle adjustment; the others are read back from the map store when a loop
  /// candidate, a BA window or a landmark track needs them. 0: all stay in RAM.
  size_t features_in_memory = 4000;
  /// Every this many seconds the heap's freed pages go back to the kernel (malloc_trim): without, the RSS
  /// stays at its high-water mark (an octree rebuild frees a whole tree). 0: never.
  double memory_trim_period_s = 10.0;
  /// Checked from the compressed images' headers before decoding: the camera a robot announced (width *
  /// height) and each compressed depth or colour image; beyond, the keyframe is refused.
  size_t max_image_pixels = 2048 * 2048;
  size_t max_image_bytes = 8u << 20;
  /// Store first, order later: a keyframe whose odometry predecessor is not in the graph yet is stored and
  /// acknowledged at once and waits in a per-robot reorder buffer. A robot with more than
  /// reorder_capacity keyframes waiting, or a keyframe that waited reorder_timeout_s, gives up on the
  /// missing predecessor: the waiting keyframes start a new chain (re-anchored by loop closure).
  size_t reorder_capacity = 64;
  double reorder_timeout_s = 10.0;
  /// Map modes. A robot announces "localize" in its Hello (a capability) to be placed in the stored map and
  /// tracked in it without changing it: its keyframes are acknowledged but never stored, and the map, its
  /// octree and its files do not change for it. allow_localize false refuses such robots' keyframes;
  /// frozen_map puts every robot in localize mode (nothing the robots send changes the map directory).
  bool allow_localize = true;
  bool frozen_map = false;
  /// When a localising robot's keyframe is believed placed (rgbdmap/backend/placement.hpp).
  PlacementConfig placement;
  /// Uncertainty of an odometry edge whose keyframe carried no information matrix (1 sigma per axis).
  double default_odometry_sigma_m = 0.02;
  double default_odometry_sigma_deg = 1.0;
  /// Uncertainty added to every edge's covariance before optimisation (1 sigma per axis); see
  /// withCovarianceFloor in rgbdmap/backend/edge_information.hpp. 0 and 0 use the information as the robot
  /// and detector computed it.
  double edge_sigma_floor_m = 0.01;
  double edge_sigma_floor_deg = 0.5;
  /// The four sigmas above, as the back-end's edge information policy takes them.
  EdgeInformationConfig edgeInformation() const {
    return {default_odometry_sigma_m, default_odometry_sigma_deg, edge_sigma_floor_m, edge_sigma_floor_deg};
  }
  /// ORB extraction for keyframes sent without features (the robot's link.send_features: false), from
  /// their decoded colour; must match the robots' odometry orb: sections.
  OrbConfig features;
  LoopDetectorConfig loop;
  PoseGraphConfig graph;
  BundleAdjustmentConfig ba;
  /// Occupancy map, built on its own worker thread, never on the ingest worker.
  bool occupancy_enabled = true;
  OccupancyMapConfig occupancy;
  SliceConfig slice;
  double slice_period_s = 0.5;  ///< at most one OccupancySlice per robot per this period (after keyframes)
  double map_stream_period_s = 2.0;  ///< MapUpdate to every robot (its own map); 0 turns the stream off
  /// After a keyframe is inserted into the octree, its map's MapUpdate goes out within this delay (the
  /// keyframes inserted meanwhile share it), not only every map_stream_period_s; 0: only periodically.
  double map_stream_delay_s = 0.25;
  /// A map store that stopped on an I/O error (a full disk) is tried again (MapStore::recover) this often;
  /// meanwhile keyframes are left unacknowledged (their robots resend them).
  double store_retry_s = 2.0;
  /// rgbdmap-server on SIGINT/SIGTERM: at most this long for queued ingest, optimisation and octree work to
  /// finish before the outputs are written, so they reflect every stored keyframe (a server that fell
  /// behind, e.g. a fleet past its map limit, catches up here).
  double stop_wait_s = 30.0;

  std::string validate() const;  ///< "" when valid, else every problem ("; "-separated)
};

/// Every key of the server's file but server.transport, keys_file and open_mode (server_config.hpp): its own
/// (server.*, map.enabled, map.stream_period_s, slice.period_s), then loop.*, graph.*, map.*, slice.*.
const ConfigTable<MapServerConfig>& mapServerConfigTable();
/// The `placement:` section (keys without the prefix).
const ConfigTable<PlacementConfig>& placementConfigTable();
/// The `ba:` section (keys without the prefix).
const ConfigTable<BundleAdjustmentConfig>& bundleAdjustmentConfigTable();

}  // namespace rgbdmap
