#pragma once
// The ingest part's counters: keyframes decoded, stored, refused and placed, loop detection, the graph's
// optimisation results applied, corrections resent, the restore, and the ingest worker's timings. The
// server's stats (MapServerStats) hold them; stats_json.cpp writes them.
#include <array>
#include <cstddef>
#include <cstdint>

#include "rgbdmap/backend/bundle_adjustment_stats.hpp"
#include "rgbdmap/intake/intake_stats.hpp"
#include "rgbdmap/loop/loop_verifier.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap {

struct IngestStats {
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
  uint64_t keyframes_localized = 0;  ///< of robots that localise: matched, acknowledged, never stored
  int keyframes_waiting = 0;         ///< in the reorder buffer: stored and acknowledged, not in the graph yet
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
  MapStoreRecovery recovery;
  uint64_t keyframes_unacked_store_failed = 0;  ///< keyframe messages (resent ones too) left unacked then
};

/// What IngestPipeline::stats() reports: its own counters and those of the parts it holds (the landmark
/// map's bundle adjustment as last applied, the Hello hold, the robots with the placement's figures).
struct IngestReport {
  IngestStats ingest;
  BundleAdjustmentStats ba;
  HelloHoldStats hello_hold;
  std::vector<ServerRobotStats> robots;
};

}  // namespace rgbdmap
