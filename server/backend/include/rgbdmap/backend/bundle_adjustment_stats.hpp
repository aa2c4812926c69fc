#pragma once
// What the map back-end's bundle adjustments did, cumulative (MapServerStats::ba, "ba" in the stats JSON).
#include <cstdint>

#include "rgbdmap/ba/landmark_map.hpp"

namespace rgbdmap {

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

}  // namespace rgbdmap
