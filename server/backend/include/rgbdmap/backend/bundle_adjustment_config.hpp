#pragma once
// Bundle adjustment in the map back-end: what the landmark map does and when adjustments run
// (server.ba.* in deploy/config/server.yaml).
#include "rgbdmap/ba/landmark_map.hpp"

namespace rgbdmap {

/// Bundle adjustment on the server: what the landmark map does and when adjustments run.
struct BundleAdjustmentConfig {
  bool enabled = true;  ///< false: the pose graph alone
  LandmarkMapConfig landmarks;
  /// New keyframes of one optimiser batch that get a local BA (the newest); the others are matched by
  /// projection only, and the next global BA catches them up.
  int max_local_per_batch = 2;
  /// A loop edge whose ends are more than this many keyframes apart (or in different chains) closes a large
  /// cycle: a global BA follows its pose-graph solve.
  int global_after_loop_span = 30;
  /// A map with this many keyframes added since its last global BA gets one (0: never for growth alone).
  int global_every_keyframes = 50;
  /// A global BA for growth or after a large cycle waits until the map has grown by this fraction of its
  /// keyframes since its last one, so its cost (linear in the map, up to the landmark map's observation cap)
  /// stays constant per keyframe as the map grows. Joined chains (a merge), an explicit request (waitIdle)
  /// and a quiet map are not held back. A global BA that ends at its time limit without lowering the
  /// error doubles its map's fraction (up to 64x) until one helps (BundleAdjustmentStats::global_fruitless).
  /// 0: no wait.
  double global_min_growth_fraction = 0.1;
  /// A map changed since its last global BA gets one once no keyframe came for this long (0: only when
  /// asked, e.g. by waitIdle).
  double global_when_idle_s = 2.0;
  /// A map of more keyframes than this gets no global BA (0: no limit); local BAs and the pose graph go
  /// on. In bench_map_growth's revisited rooms every global BA past ~4,000 keyframes ran out of its time and
  /// was refused (edges between keyframes sharing landmarks changed by metres), while its window, at least
  /// landmarks.min_frame_observations per keyframe, grew with the map: the RSS rose by 0.66-0.70 GB during
  /// each one at 12,800-16,000 keyframes (docs/scaling.md). A windowed or submap global step is
  /// not built.
  int global_max_keyframes = 4000;
  /// An adjustment that changes the relative pose of two keyframes sharing landmarks (an edge between
  /// them) by more than this is refused, nothing applied: shared landmarks hold such a relative pose to
  /// centimetres, and a change this large is a solve gone wrong (a global BA out of time in a
  /// 5,000-keyframe map moved 187 of them by up to 11.8 m). 0: no check.
  /// A global BA takes the pose-graph edges its landmarks do not cover (keyframes sharing fewer than
  /// landmarks.min_covisibility: odometry steps into a room not seen before) as relative-pose priors, so its
  /// optimum agrees with the pose graph's and a whole-graph solve after it has little left to move. Off until
  /// measured beyond 2,400 keyframes and in the fleet (docs/scaling.md).
  bool global_step_priors = false;
  double max_edge_change_m = 0.5;
  double max_edge_change_deg = 15.0;
};

}  // namespace rgbdmap
