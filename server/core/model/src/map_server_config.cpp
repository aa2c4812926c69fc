#include "rgbdmap/model/map_server_config.hpp"

#include "rgbdmap/ba/ba_config_table.hpp"
#include "rgbdmap/graph/pose_graph_config_table.hpp"
#include "rgbdmap/loop/loop_config_tables.hpp"
#include "rgbdmap/map/map_config_tables.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/vision/vision_config_tables.hpp"

namespace rgbdmap {
namespace {

using C = MapServerConfig;

// The server's own values (its parts have tables of their own).
const ConfigTable<C>& ownTable() {
  using R = ConfigRange;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("server.map_dir", &C::map_dir,
               "durable keyframes, loop edges and robot cameras; a restart on it resumes the map")
          .add("server.robots", &C::robots,
               "robots to serve, comma-separated (\"robot0,robot1\"); empty: any robot the keys "
               "admit, via an \"rgbdmap/*\" subscription (LCM only; DDS needs the list)")
          .add("server.store_sync", &C::store_sync,
               "fdatasync every keyframe before acknowledging it (durability)")
          .add("server.status_period_s", &C::status_period_s, ConfigRange::closed(0.0, 3600.0),
               "ServerStatus to every robot (s); 0: off")
          .add("server.loop_edges_max", &C::loop_edges_max, R::closed(0, msg::kMaxLoopEdges),
               "LoopEdges to each robot after an optimisation (for visualisers): the newest this many "
               "enabled loop edges of its map; 0: none")
          .add("server.ingest_queue_capacity", &C::ingest_queue_capacity, R::closed(1, 1000000),
               "keyframes waiting for the worker, all robots together; beyond, they are left "
               "unacknowledged (the robot resends them) and counted as queue_full")
          .add("server.robot_queue_capacity", &C::robot_queue_capacity, R::closed(1, 100000),
               "keyframes one robot may have waiting; each robot has its own queue, served round-robin, so "
               "a robot sending faster than the server ingests delays only itself; beyond, left "
               "unacknowledged and counted as queue_full")
          .add("server.robot_queue_bytes", &C::robot_queue_bytes, R::closed(1024, size_t(1) << 30),
               "encoded bytes one robot may have waiting (one keyframe always fits an empty queue)")
          .add("server.robot_max_keyframes_per_s", &C::robot_max_keyframes_per_s, R::closed(0.0, 1e6),
               "keyframe messages per robot and second (retransmissions included), a token bucket checked "
               "before decoding; beyond, left unacknowledged and counted as throttled; 0: off. A robot "
               "makes a few keyframes per second, the server ingests ~30 per second on two cores")
          .add("server.background_nice", &C::background_nice, R::closed(0, 19),
               "the optimiser and octree-rebuild threads run this much nicer than the server (Linux nice, "
               "per thread): under overload decode, ingest (storage, acknowledgements) and the map worker "
               "(slices) get the cores first, while optimisation and rebuilds batch their queued work; 0: "
               "all threads equal")
          .add("server.features_in_memory", &C::features_in_memory, R::closed(0, 100000000),
               "the features of this many keyframes (the most recently used, ~85 KB each at 1,000 "
               "features) stay in RAM for loop closure and bundle adjustment; the others are read back "
               "from the map store when needed; 0: all stay in RAM")
          .add("server.memory_trim_period_s", &C::memory_trim_period_s, R::closed(0.0, 3600.0),
               "every this many seconds the heap's freed pages go back to the kernel (malloc_trim): "
               "without, the RSS stays at its high-water mark (an octree rebuild frees a whole tree); "
               "0: never")
          .add("server.robot_keyframe_burst", &C::robot_keyframe_burst, R::closed(1.0, 1e6),
               "the bucket's size: keyframes a robot may send at once, e.g. the retransmissions of its whole "
               "send window (client max_pending) when its link comes back after an outage")
          .add("server.max_image_pixels", &C::max_image_pixels, R::closed(1, 4096 * 4096),
               "largest camera (width * height) whose keyframes are decoded; checked, with the image size "
               "against the robot's Hello, from the compressed images' headers before decoding")
          .add("server.max_image_bytes", &C::max_image_bytes, R::closed(1024, size_t(1) << 30),
               "largest compressed depth or colour image of a keyframe; beyond, refused before decoding")
          .add("server.reorder_capacity", &C::reorder_capacity, R::closed(1, 100000),
               "keyframes per robot stored and acknowledged but waiting for their odometry predecessor; "
               "beyond, the oldest waiting ones give it up and start a new chain (re-anchored by loops)")
          .add("server.reorder_timeout_s", &C::reorder_timeout_s, R::closed(0.0, 3600.0),
               "a keyframe waits at most this long for its predecessor, then starts a new chain")
          .add("server.allow_localize", &C::allow_localize,
               "robots may ask (in their Hello) to localise in the map without changing it; false refuses "
               "their keyframes")
          .add("server.frozen_map", &C::frozen_map,
               "every robot localises in the stored map (as if it asked to): keyframes are acknowledged, "
               "never stored; the map directory does not change")
          .add("server.default_odometry_sigma_m", &C::default_odometry_sigma_m, R::closedOpen(1e-4, 10.0),
               "odometry edge uncertainty when a keyframe carries no information matrix")
          .add("server.default_odometry_sigma_deg", &C::default_odometry_sigma_deg, R::closedOpen(1e-3, 90.0),
               "")
          .add("server.edge_sigma_floor_m", &C::edge_sigma_floor_m, R::closed(0.0, 10.0),
               "added to every edge's covariance (1 sigma): the Hessian-based information of refinement is "
               "sub-millimetre and would make real drift look like outliers")
          .add("server.edge_sigma_floor_deg", &C::edge_sigma_floor_deg, R::closed(0.0, 90.0), "")
          .add("map.enabled", &C::occupancy_enabled,
               "false: no octree, no slices, no map stream, no map files")
          .add("map.stream_period_s", &C::map_stream_period_s, R::closed(0.0, 3600.0),
               "MapUpdate to every robot (its own map; full first and after rebuilds) at least this "
               "often; 0: off")
          .add("map.stream_delay_s", &C::map_stream_delay_s, R::closed(0.0, 60.0),
               "a keyframe's voxels go out within this delay after its insertion into the octree (the "
               "keyframes inserted meanwhile share one partial update); 0: only every stream_period_s")
          .add("slice.period_s", &C::slice_period_s, R::closed(0.0, 3600.0),
               "at most one slice per robot per this period")
          .add("server.store_retry_s", &C::store_retry_s, R::closed(0.05, 3600.0),
               "a map store stopped by an I/O error (a full disk) is tried again this often (s); until it "
               "recovers, keyframes are left unacknowledged and the robots resend them")
          .add("server.stop_wait_s", &C::stop_wait_s, R::closed(0.0, 3600.0),
               "rgbdmap-server on SIGINT/SIGTERM waits at most this long (s) for queued ingest, optimisation "
               "and octree work before it writes its outputs, so they reflect every stored keyframe");
  return table;
}

}  // namespace

const ConfigTable<PlacementConfig>& placementConfigTable() {
  using P = PlacementConfig;
  using R = ConfigRange;
  static const ConfigTable<P> table =
      ConfigTable<P>()
          .add("first_min_agreeing", &P::first_min_agreeing, R::closed(1, 100),
               "a first placement needs this many verified matches to distinct map keyframes that agree on "
               "the keyframe's pose (or two successive keyframes whose matches agree on the odometry frame)")
          .add("agree_m", &P::agree_m, R::closedOpen(0.001, 10.0), "matches agree within this distance ...")
          .add("agree_deg", &P::agree_deg, R::closedOpen(0.01, 180.0), "... and this rotation")
          .add("track_gate_m", &P::track_gate_m, R::closedOpen(0.001, 100.0),
               "once placed, a match farther than this from the pose odometry predicts is not believed")
          .add("track_gate_deg", &P::track_gate_deg, R::closedOpen(0.01, 180.0), "");
  return table;
}

const ConfigTable<BundleAdjustmentConfig>& bundleAdjustmentConfigTable() {
  using B = BundleAdjustmentConfig;
  using R = ConfigRange;
  static const ConfigTable<B> table =
      ConfigTable<B>()
          .add("enabled", &B::enabled, "false: the pose graph alone, no landmarks")
          .add("max_local_per_batch", &B::max_local_per_batch, R::closed(0, 1000),
               "new keyframes of one optimiser batch that get a local BA (the newest)")
          .add("global_after_loop_span", &B::global_after_loop_span, R::closed(1, 1000000),
               "a loop whose ends are more keyframes apart than this (or in two chains) is followed by a "
               "global BA")
          .add("global_every_keyframes", &B::global_every_keyframes, R::closed(0, 1000000),
               "a global BA after this many new keyframes of a map (0: not for growth alone)")
          .add("global_min_growth_fraction", &B::global_min_growth_fraction, R::closed(0.0, 10.0),
               "a global BA for growth or after a large cycle waits until the map has grown by this "
               "fraction of its keyframes since its last one (cost per keyframe flat in map size; 0: no "
               "wait)")
          .add("global_when_idle_s", &B::global_when_idle_s, R::closed(0.0, 3600.0),
               "a global BA of a changed map once no keyframe came for this long (0: only on request)")
          .add("global_max_keyframes", &B::global_max_keyframes, R::closed(0, 100000000),
               "a map of more keyframes gets no global BA (past ~4,000 they ran out of time and were "
               "refused, their window growing with the map; 0: no limit)")
          .add("global_step_priors", &B::global_step_priors,
               "a global BA takes the pose-graph edges its landmarks do not cover (odometry steps into an "
               "unseen room) as relative-pose priors")
          .add("max_edge_change_m", &B::max_edge_change_m, R::closed(0.0, 1000.0),
               "an adjustment that changes the relative pose of two keyframes sharing landmarks by more "
               "than this is refused (a solve gone wrong; 0: no check)")
          .add("max_edge_change_deg", &B::max_edge_change_deg, R::closed(0.0, 180.0), "the same in rotation")
          .nest("", &B::landmarks, landmarkMapConfigTable());
  return table;
}

const ConfigTable<MapServerConfig>& mapServerConfigTable() {
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .section("server", "")  // the sections in this order
          .section("features", "")
          .section("loop", "")
          .section("graph", "")
          .section("ba", "")
          .section("map", "")
          .section("slice", "")
          .append(ownTable())
          .section("placement",
                   "a robot that localises in the stored map (its Hello asks, or server.frozen_map): when "
                   "its keyframe's verified matches with map keyframes are believed")
          .nest("placement.", &C::placement, placementConfigTable())
          .section("features",
                   "ORB features the server extracts from the decoded colour of keyframes sent "
                   "without them (the robots' link.send_features: false); keep equal to the "
                   "robots' odometry orb: sections")
          .nest("features.", &C::features, orbConfigTable())
          .section("loop", "loop closure, Hu et al. 2017 section 3.2, plus nearby and appearance candidates")
          .nest("loop.", &C::loop, loopDetectorConfigTable())
          .section("graph", "Ceres pose graph on SE(3)")
          .nest("graph.", &C::graph, poseGraphConfigTable())
          .section("ba",
                   "bundle adjustment: landmark tracks, local BA after each keyframe, global BA "
                   "after large loops, merges and when the map is quiet")
          .nest("ba.", &C::ba, bundleAdjustmentConfigTable())
          .section("map", "occupancy octree, built on the server's map worker thread")
          .nest("map.", &C::occupancy, occupancyMapConfigTable())
          .section("slice", "OccupancySlice to each robot after its keyframes (ROS OccupancyGrid values)")
          .nest("slice.", &C::slice, sliceConfigTable());
  return table;
}

std::string MapServerConfig::validate() const {
  std::vector<std::string> problems = ownTable().problems(*this);
  if (map_dir.empty()) problems.push_back("map_dir is empty");
  for (const std::string& r : robots)
    if (!msg::channelFor(msg::MessageType::kHello, r)) problems.push_back("invalid robot id '" + r + "'");
  if (const std::string f = joinProblems(orbConfigTable().problems(features)); !f.empty())
    problems.push_back("features: " + f);
  if (const std::string l = loop.validate(); !l.empty()) problems.push_back(l);
  if (const std::string g = joinProblems(poseGraphConfigTable().problems(graph)); !g.empty())
    problems.push_back("graph: " + g);
  if (const std::string b = joinProblems(bundleAdjustmentConfigTable().problems(ba)); !b.empty())
    problems.push_back("ba: " + b);
  if (const std::string p = joinProblems(placementConfigTable().problems(placement)); !p.empty())
    problems.push_back("placement: " + p);
  if (occupancy_enabled) {
    if (const std::string o = occupancy.validate(); !o.empty()) problems.push_back("occupancy: " + o);
    if (const std::string sl = slice.validate(); !sl.empty()) problems.push_back("slice: " + sl);
  }
  return joinProblems(problems);
}

}  // namespace rgbdmap
