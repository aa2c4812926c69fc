#include "rgbdmap/server/stats_json.hpp"

namespace rgbdmap {

Json bundleAdjustmentJson(const BundleAdjustmentStats& s) {
  const LandmarkStats& l = s.landmarks;
  return {{"landmarks", l.landmarks},
          {"observations", l.observations},
          {"links_from_matches", l.links_from_matches},
          {"links_from_projection", l.links_from_projection},
          {"landmarks_fused", l.fusions},
          {"observations_rejected", l.observations_rejected},
          {"landmarks_culled", l.landmarks_culled},
          {"loop_edges_in_tracks", s.edges_in_tracks},
          {"loop_edges_taken_back", s.edges_taken_back},
          {"local_ba_runs", s.local_runs},
          {"local_ba_failures", s.local_failures},
          {"local_ba_ms_median", jsonNumber(s.local_ms_median)},
          {"local_ba_ms_p90", jsonNumber(s.local_ms_p90)},
          {"local_ba_cpu_ms_median", jsonNumber(s.local_cpu_ms_median)},
          {"local_ba_cpu_ms_p90", jsonNumber(s.local_cpu_ms_p90)},
          {"global_ba_runs", s.global_runs},
          {"global_ba_ms_last", jsonNumber(s.global_ms_last)},
          {"global_ba_fruitless", s.global_fruitless},
          {"global_ba_skipped", s.global_skipped},
          {"ba_refused", s.refused},
          {"ba_parts_kept", s.parts_kept},
          {"ba_part_shift_m_max", jsonNumber(s.part_shift_m_max)},
          {"global_ba_ms_max", jsonNumber(s.global_ms_max)},
          {"global_ba_cpu_ms_last", jsonNumber(s.global_cpu_ms_last)},
          {"global_ba_cpu_ms_max", jsonNumber(s.global_cpu_ms_max)},
          {"global_ba_keyframes_last", s.global_keyframes_last},
          {"ba_out_of_time", s.out_of_time}};
}

}  // namespace rgbdmap
