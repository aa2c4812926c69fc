#pragma once
// The server's occupancy map: every keyframe's depth integrated into an OctoMap octree at its
// optimised pose, one tree per map id (a pose-graph component), rebuilt from the kept keyframe clouds in a
// background worker when a loop closure or a merge moves keyframes, and swapped in atomically.
// Algorithms only: plain structs in and out, no transport, no files (map_io.hpp does bytes and files).
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/common/serial_worker.hpp"

namespace octomap {
class OcTree;
}
namespace rgbdmap::detail {
class CloudSpill;
}

namespace rgbdmap {

struct OccupancyMapConfig {
  double resolution_m = 0.05;  ///< leaf size of the octree
  /// Depth beyond this is not inserted as occupied, but its ray still clears free space up to max_range_m
  /// (OctoMap's maxrange semantics): far depth is noisy (sigma grows with z^2), the space before it is not.
  double max_range_m = 4.0;
  double min_range_m = 0.3;  ///< closer depth is dropped (no ray): below the sensor's working range
  double prob_hit = 0.7, prob_miss = 0.4, clamp_min = 0.12, clamp_max = 0.97;  ///< OctoMap sensor model
  double rebuild_translation_m =
      0.03;  ///< a keyframe moved more than this (or rotation below) triggers a rebuild
  double rebuild_rotation_rad = 0.02;
  /// A rebuild re-integrates only what moved when the keyframes that moved (or joined or left the map) are at
  /// most this fraction of the map's keyframes: the octree cells their rays touch, at the old and the new
  /// poses, are recomputed from every keyframe whose rays reach them (the result equals a whole rebuild).
  /// Above it, or 0, the whole tree is rebuilt from every kept cloud.
  double partial_rebuild_max_fraction = 0.5;
  /// MB of the moved keyframes' scan updates a partial rebuild keeps from its first pass (finding the cells)
  /// for its second (recomputing them); beyond, they are cast again. ~0.1 MB each at 320 x 240: unbounded,
  /// they were 378 MB of the heap's peak at 5,000 keyframes (heaptrack).
  int partial_rebuild_held_mb = 64;
  /// The rebuild thread's nice above the process (set by the server from server.background_nice; not a
  /// map: key).
  int rebuild_nice = 0;
  /// Pixel sampling step in both image directions (1 = every pixel). 0 = automatic: the largest step whose
  /// footprint at max_range_m stays within one cloud voxel (stride * max_range / fx <= cloud voxel), i.e.
  /// 3 at 0.05 m and 1 at 0.02 m for a 517 px focal length; reading more pixels adds no voxels.
  int pixel_stride = 0;
  /// Side of the camera-frame voxel grid the kept cloud is reduced to, as a fraction of resolution_m (one
  /// point, the mean of its pixels, per cube). 0.5 keeps (nearly) every octree leaf the full cloud would
  /// touch while storing ~10x fewer points for rebuilds. 0 = no reduction.
  double cloud_voxel_fraction = 0.5;
  bool keep_colors = true;  ///< keep one RGB per kept point (for coloured exports); costs 3 bytes/point
  /// The newest this many kept clouds stay in RAM; older ones are moved to an anonymous file in spill_dir
  /// and read back when a rebuild or an export needs them (0: every cloud stays in RAM). Without a
  /// spill_dir every cloud stays in RAM.
  size_t clouds_in_memory = 1000;
  /// Directory of the spill file (set by the server to its map directory; not a map: key). Empty: no spill.
  std::string spill_dir;
  /// Changed leaves remembered for partial map streams (MapStream); older consumers get a full tree.
  size_t stream_journal_max_keys = 2'000'000;

  std::string validate() const;  ///< "" when valid, else all problems "; "-separated
  double cloudVoxelM() const { return cloud_voxel_fraction * resolution_m; }
  int pixelStride(double fx) const;  ///< pixel_stride, or the automatic one for this focal length
};

/// One keyframe's depth reduced once to the points to insert (camera frame) + colours; kept for rebuilds.
struct KeyframeCloud {
  int64_t keyframe_id = 0;
  std::vector<Eigen::Vector3f> points_cam;
  std::vector<std::array<uint8_t, 3>> colors_rgb;  ///< empty or parallel to points_cam
  size_t memoryBytes() const;
};

/// Undistorted unit-depth rays (x/z, y/z) of the sampled pixels of one camera, computed once and reused for
/// every keyframe of that camera (undistorting per pixel per keyframe would cost more than the insertion).
class KeyframeCloudMaker {
 public:
  KeyframeCloudMaker(const PinholeCamera& camera, const OccupancyMapConfig& config);
  /// depth16: CV_16UC1 raw units (metres = value / depth_scale); bgr: CV_8UC3 of the same size or empty.
  /// Fails on wrong types/sizes or a non-positive/non-finite depth_scale.
  Result<KeyframeCloud> make(int64_t keyframe_id, const cv::Mat& depth16, double depth_scale,
                             const cv::Mat& bgr) const;
  int stride() const { return stride_; }

 private:
  OccupancyMapConfig config_;
  int width_, height_, stride_;
  std::vector<Eigen::Vector2f> rays_;  ///< per sampled pixel, row-major over the sampled grid
};

/// One-shot form of KeyframeCloudMaker (builds the ray table each call). NaN-free by construction.
Result<KeyframeCloud> makeKeyframeCloud(int64_t keyframe_id, const cv::Mat& depth16, double depth_scale,
                                        const cv::Mat& bgr, const PinholeCamera& camera,
                                        const OccupancyMapConfig& config);

struct OccupancyMapStats {
  int maps = 0;
  size_t keyframes = 0;
  size_t leaf_nodes = 0, occupied_leaves = 0, free_leaves = 0;
  size_t tree_memory_bytes = 0;       ///< octomap::OcTree::memoryUsage() summed over the trees
  size_t journal_bytes = 0;           ///< the stream journals' keys (map streams' changed leaves)
  size_t clouds_memory_bytes = 0;     ///< kept keyframe clouds in RAM
  size_t clouds_spilled = 0;          ///< kept clouds moved to the spill file (clouds_in_memory)
  uint64_t spill_file_bytes = 0;      ///< the spill file's size
  uint64_t spill_failures = 0;        ///< spill writes or reads that failed (a failed read skips the cloud)
  uint64_t rebuilds = 0;              ///< trees rebuilt and swapped in, or updated where keyframes moved
  uint64_t partial_rebuilds = 0;      ///< of them, updated only where keyframes moved
  size_t last_rebuild_keyframes = 0;  ///< clouds the last rebuild integrated (cast), moved ones twice
  double last_rebuild_ms = 0.0;       ///< wall time of the last rebuild (build + catch-up)
  double last_rebuild_cpu_ms = 0.0;   ///< the worker thread's CPU time for it (wall time minus waiting)
  size_t pending_rebuilds = 0;        ///< map ids waiting for (or in) a rebuild
};

/// A partial or full octree for a map stream (see OccupancyMap::streamSince and map_io.hpp).
struct MapStreamChunk {
  int map_id = 0;
  uint64_t revision = 0;       ///< the tree revision these bytes show; pass it to the next streamSince()
  bool full = true;            ///< false: only the leaves changed since the given revision
  size_t changed_leaves = 0;   ///< partial: leaves carried
  std::vector<uint8_t> bytes;  ///< serializeTree() format
};

/// Thread-safe. Trees are per map id (a graph component); readers never see a half-built tree.
class OccupancyMap {
 public:
  explicit OccupancyMap(OccupancyMapConfig config);  ///< config must validate() (checked by the caller)
  ~OccupancyMap();  ///< stops the rebuild worker (a running rebuild is abandoned)
  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// Integrates now (caller's thread) into the tree of `map_id` and keeps the cloud for rebuilds. Fails on a
  /// duplicate id, a non-finite pose or non-finite points.
  Status insert(KeyframeCloud cloud, int map_id, const SE3& T_map_cam);
  /// New poses/map ids of known keyframes (unknown ids and non-finite poses ignored). If any keyframe moved
  /// beyond the thresholds (relative to the pose it was integrated at) or changed map id, the affected trees
  /// are rebuilt from the kept clouds on a background worker (requests coalesce) and swapped in atomically;
  /// keyframes inserted during a rebuild are not lost. Returns true if a rebuild was scheduled.
  bool updatePoses(const std::map<int64_t, std::pair<int, SE3>>& map_id_and_T_map_cam);
  bool waitIdle(double timeout_s) const;  ///< until no rebuild is pending or running; false on timeout
  /// Calls fn(const octomap::OcTree&) under a shared lock on map_id's current tree; false if none.
  bool read(int map_id, const std::function<void(const octomap::OcTree&)>& fn) const;
  std::vector<int> mapIds() const;
  uint64_t revision(int map_id) const;  ///< increases on every insert and swap (0: no such map)
  OccupancyMapStats stats() const;
  /// A kept keyframe cloud with the map id and pose it has now (the latest updatePoses), for exports.
  struct KeptCloud {
    std::shared_ptr<const KeyframeCloud> cloud;
    int map_id = 0;
    SE3 T_map_cam = SE3::Identity();
  };
  /// In keyframe id order; shares the clouds in RAM, reads the spilled ones back (a cloud that cannot be
  /// read is left out and counted in spill_failures).
  std::vector<KeptCloud> keptClouds() const;
  /// Why clouds are not spilled although spill_dir is set (the spill file could not be opened), else "".
  const std::string& spillError() const { return spill_error_; }
  const OccupancyMapConfig& config() const { return config_; }

  /// Stream bytes of map_id for a consumer that holds revision `since` (0 = nothing): the changed leaves
  /// only when the tree was not swapped since, the journal still covers it and that is smaller than the
  /// full tree; otherwise the full tree. Fails if the map does not exist.
  Result<MapStreamChunk> streamSince(int map_id, uint64_t since) const;

  /// A kept cloud: in RAM, or where it is in the spill file.
  struct CloudHandle {
    std::shared_ptr<const KeyframeCloud> cloud;
    uint64_t spill_offset = 0, spill_bytes = 0;
  };
  struct Slot;  // one map id's tree, its integrated poses and change journal (occupancy_map_detail.hpp)

 private:
  struct Entry {
    CloudHandle cloud;
    int map_id = 0;
    SE3 T_map_cam = SE3::Identity();
    uint64_t order = 0;  ///< insertion order (rebuilds integrate in it)
    Eigen::AlignedBox3f
        box_cam;            ///< the cloud's points and the camera centre (bounds every ray), camera frame
    bool inserting = true;  ///< registered, its insert() has not integrated it yet
  };
  void integrateInserted(int64_t keyframe_id, const std::shared_ptr<Slot>& slot);
  /// The cloud in RAM, or read back from the spill file (nullptr on a failed read, counted). No lock held.
  std::shared_ptr<const KeyframeCloud> load(int64_t keyframe_id, const CloudHandle& handle) const;
  /// Moves the oldest clouds in RAM beyond clouds_in_memory to the spill file (the caller's thread).
  void spillOldClouds();
  bool isDirtyLocked(int map_id) const;
  /// Queues a rebuild of map_id behind the maps already dirty (first dirty, first rebuilt: a map corrected
  /// all the time does not starve the others).
  void markDirtyLocked(int map_id);
  /// Drops the trees of the touched maps that no keyframe is in any more (merged away).
  void dropEmptyMapsLocked(const std::set<int>& touched);
  void rebuildNext();  ///< a task on rebuild_worker_: one per map id that became dirty
  void rebuild(int map_id);
  /// Updates map_id's tree only where keyframes moved (see partial_rebuild_max_fraction); false when that
  /// does not apply (too many moved, no tree yet) and the caller rebuilds the whole tree.
  bool rebuildPartly(int map_id);
  /// Counters and timing of a finished rebuild; marks the map dirty again if it moved meanwhile.
  void finishRebuildLocked(int map_id, size_t keyframes_cast, std::chrono::steady_clock::time_point t0,
                           double cpu0);

  const OccupancyMapConfig config_;
  std::unique_ptr<detail::CloudSpill> spill_;  ///< null: every cloud stays in RAM
  std::string spill_error_;
  mutable std::atomic<uint64_t> spill_failures_{0};
  std::deque<int64_t> in_memory_;  ///< keyframes whose cloud is in RAM, oldest first (guarded by mutex_)
  mutable std::mutex mutex_;       ///< entries_, slots_, slots' integrated poses, dirty_, counters
  std::map<int64_t, Entry> entries_;
  std::map<int, std::shared_ptr<Slot>> slots_;
  std::deque<int> dirty_;  ///< map ids to rebuild, in the order they became dirty; each has a task queued
  bool busy_ = false;              ///< a rebuild runs
  std::atomic<bool> stop_{false};  ///< abandons a running rebuild
  uint64_t next_order_ = 0;
  uint64_t next_revision_ = 1;
  uint64_t rebuilds_ = 0;
  uint64_t partial_rebuilds_ = 0;
  size_t last_rebuild_keyframes_ = 0;
  double last_rebuild_ms_ = 0.0;
  double last_rebuild_cpu_ms_ = 0.0;
  SerialWorker rebuild_worker_{
      SerialWorkerOptions{"rgbdmap-rebuild", 0, 0.0, {}, config_.rebuild_nice}};  ///< last: stopped first
};

}  // namespace rgbdmap
