#pragma once
// The MapServer's map worker: its own thread and queue (a SerialWorker), fed by the ingest worker, so that
// octree work (cloud reduction ~2 ms, insertion ~8 ms CPU per keyframe) never delays ingestion and
// acknowledgements.
//   - keyframes (decoded images, or read back from the store on restart) -> KeyframeCloud -> OccupancyMap;
//   - optimised poses, in queue order after the keyframes they move -> OccupancyMap::updatePoses (the
//     rebuild itself runs on OccupancyMap's own background worker); updates not applied yet coalesce;
//   - after a live keyframe of robot R (at most every slice_period_s): R's slice at R's newest keyframe,
//     published to R;
//   - a MapUpdate of each robot's map to that robot (full on first send and after a rebuild or a change of
//     map, the changed leaves otherwise) within map_stream_delay_s of a keyframe's insertion (the stream
//     is checked every map_stream_delay_s; keyframes inserted meanwhile share one update), and at least
//     every map_stream_period_s (rebuilds swap in off this thread).
#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/common/sample_reservoir.hpp"
#include "rgbdmap/common/serial_worker.hpp"
#include "rgbdmap/map/occupancy_map.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/model/server_keyframe.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap {

/// What the map worker is configured by (the server's map.*, slice.* and background_nice, see
/// MapServerConfig).
struct MapWorkerConfig {
  OccupancyMapConfig occupancy;  ///< with the rebuild thread's nice and the spill directory set
  SliceConfig slice;
  double slice_period_s = 0.5;       ///< at most one slice per robot per this period (after keyframes)
  double map_stream_period_s = 2.0;  ///< a MapUpdate to every robot at least this often; 0: no stream
  double map_stream_delay_s = 0.25;  ///< ... and this soon after a keyframe's insertion; 0: only periodically
};

struct MapServerConfig;
/// The map worker's part of a server configuration: the rebuild thread runs background_nice, old clouds are
/// spilled to the map directory.
MapWorkerConfig mapWorkerConfig(const MapServerConfig& server);

/// One keyframe handed to the map worker. Empty depth: read its images from the store (restart).
struct MapKeyframeJob {
  int64_t node_id = 0;
  std::string robot_id;
  int map_id = 0;
  SE3 T_map_kf = SE3::Identity();
  CameraIntrinsics camera;
  cv::Mat depth;         ///< CV_16UC1 raw units
  cv::Mat color;         ///< CV_8UC3 BGR or empty
  bool live = true;      ///< a just-received keyframe (a slice follows); false when restored
  int keyframe_id = -1;  ///< the robot's id of it (MapUpdate::robot_keyframe_id)
  /// The epoch of the newest pose update (updatePoses) taken before T_map_kf was: a later one knows a
  /// newer pose of it.
  uint64_t pose_epoch = 0;
};

struct MapNodePose {
  int64_t node_id = 0;
  int map_id = 0;
  SE3 T_map_kf = SE3::Identity();
};

struct MapWorkerPublishers {
  std::function<void(const std::string& robot_id, const msg::OccupancySlice&)> slice;
  std::function<void(const std::string& robot_id, const msg::MapUpdate&)> map;
};

/// The map worker's counters (zero when occupancy is off): octree, kept clouds, slices and map streams.
struct MapWorkerStats {
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
};

class MapWorker {
 public:
  /// Live keyframe jobs that may wait with their decoded images (~1.5 MB each at 640x480). When the octree
  /// falls behind ingestion (many robots), a further job waits without them and reads them back from the
  /// store when its turn comes, as a restored one does: memory stays bounded, no keyframe is left out.
  static constexpr size_t kMaxQueuedImages = 32;

  /// config comes from a MapServerConfig that validates; store must outlive the worker (readKeyframe is
  /// thread-safe).
  MapWorker(const MapWorkerConfig& config, const MapStore& store, MapWorkerPublishers publishers);
  ~MapWorker();  ///< stop()
  MapWorker(const MapWorker&) = delete;
  MapWorker& operator=(const MapWorker&) = delete;

  void start();
  void stop();  ///< abandons queued work; idempotent

  void addKeyframe(MapKeyframeJob job);
  /// Every keyframe's pose as of `epoch` (increasing, > 0). Updates not applied yet coalesce: the newest
  /// replaces them (each holds the whole map's poses, and a worker behind by thousands of keyframes would
  /// otherwise hold one copy per optimisation). Poses of keyframes queued but not inserted yet are kept
  /// for them and used when they are newer than the job's (MapKeyframeJob::pose_epoch).
  void updatePoses(std::vector<MapNodePose> poses, uint64_t epoch);
  /// The pose a keyframe is inserted at now (after the pose updates applied), if it is.
  std::optional<MapNodePose> insertedPose(int64_t node_id) const;
  /// Queue empty, nothing in progress and no octree rebuild pending; false on timeout.
  bool waitIdle(double timeout_s) const;
  /// A robot that localises in the map (its keyframes are not inserted): its slice cut from the tree of
  /// `map_id` at T_map_kf, at most every slice_period_s, queued behind the work already queued.
  void sliceAt(const std::string& robot_id, int map_id, const SE3& T_map_kf);
  /// An unplaced localising robot's keyframe (decoded images, T_map_kf in its provisional frame): into a
  /// scratch tree of the robot's own, which is never stored, streamed or written, and from which its slice
  /// is cut until it is placed. The scratch tree holds at most the robot's newest kScratchKeyframes (it
  /// starts again beyond), so a robot that is never placed does not grow the server.
  void addScratchKeyframe(MapKeyframeJob job);
  /// The robot was placed: its scratch tree is dropped.
  void dropScratch(const std::string& robot_id);
  static constexpr int kScratchKeyframes = 60;
  /// Queues a map stream publication (what the stream period does) behind the work already queued.
  void flushStreams();
  void fillStats(MapWorkerStats* stats) const;
  /// See MapServer::writeMapOutputs; `keyframes` give the robots' optimised trajectories.
  Status writeOutputs(const std::string& out_dir, const std::vector<ServerKeyframe>& keyframes) const;

 private:
  struct NodeState {
    std::string robot_id;
    int map_id = 0;
    SE3 T_map_kf = SE3::Identity();
  };
  struct StreamState {
    int map_id = -1;
    uint64_t revision = 0;
  };

  bool readBackImages(MapKeyframeJob& job) const;  ///< a restored keyframe's images, from the store
  void insertKeyframe(MapKeyframeJob& job);
  void applyPendingPoses();
  /// True (and the robot's slice clock restarted) when its last slice is slice_period_s old or none was sent.
  bool sliceDue(const std::string& robot_id);
  void publishSlice(const std::string& robot_id);  ///< at the robot's newest inserted keyframe
  void publishSliceAt(const std::string& robot_id, int map_id, const SE3& T_map_kf);
  void publishStreams();
  void onStreamTick();  ///< the worker's period: publishStreams() when a keyframe came in or it is time
  const KeyframeCloudMaker& makerFor(const std::string& robot_id, const CameraIntrinsics& camera);
  void insertScratch(MapKeyframeJob& job);

  const MapWorkerConfig config_;
  const MapStore& store_;
  const MapWorkerPublishers publishers_;
  OccupancyMap occupancy_;

  // worker-only state
  std::map<std::string, std::pair<CameraIntrinsics, std::unique_ptr<KeyframeCloudMaker>>> makers_;
  std::map<std::string, StreamState> streams_;
  std::map<std::string, double> last_slice_s_;  ///< steady-clock seconds of each robot's last slice
  struct Scratch {
    std::unique_ptr<OccupancyMap> tree;  ///< map id 0, the robot's provisional frame
    int keyframes = 0;
  };
  std::map<std::string, Scratch> scratch_;  ///< unplaced localising robots' scratch trees
  /// Poses of the newest update applied, for keyframes not inserted then (node id -> pose).
  std::unordered_map<int64_t, MapNodePose> early_poses_;
  uint64_t early_epoch_ = 0;    ///< that update's epoch
  bool stream_dirty_ = false;   ///< a keyframe was inserted since the last publishStreams
  double last_stream_s_ = 0.0;  ///< steady-clock seconds of the last publishStreams

  // shared with readers (stats, outputs)
  mutable std::mutex state_mutex_;
  std::map<int64_t, NodeState> nodes_;
  std::map<std::string, int64_t> newest_;       ///< robot -> its newest inserted node
  std::map<std::string, int> newest_keyframe_;  ///< robot -> the keyframe id of its newest inserted one
  std::map<std::string, msg::OccupancySlice> last_slices_;
  SampleReservoir insert_ms_;
  SampleReservoir slice_ms_;
  size_t inserted_ = 0;
  std::atomic<size_t> queued_images_{0};      ///< queued jobs that carry decoded images
  std::atomic<uint64_t> images_deferred_{0};  ///< jobs queued without them (kMaxQueuedImages)

  std::mutex poses_mutex_;                  ///< the three below
  std::vector<MapNodePose> pending_poses_;  ///< the newest pose update, not applied yet
  uint64_t pending_epoch_ = 0;
  bool poses_queued_ = false;  ///< a task that applies pending_poses_ is queued
  std::atomic<uint64_t> pose_updates_coalesced_{0};
  uint64_t slices_sent_ = 0, map_updates_sent_ = 0, map_bytes_sent_ = 0;

  SerialWorker worker_;  ///< keyframes and pose updates in order, the map stream as its period; last member
};

}  // namespace rgbdmap
