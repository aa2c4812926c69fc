#include "rgbdmap/server/stats_json.hpp"

namespace rgbdmap {
namespace {

Json loopsJson(const MapServerStats& s) {
  Json rejected = Json::object();
  for (int r = 1; r < kLoopRejectionCount; ++r)
    rejected[toString(static_cast<LoopRejection>(r))] = s.loops_rejected_by_reason[r];
  return {{"loops_accepted", s.loops_accepted},
          {"loops_disabled", s.loops_disabled},
          {"loop_candidates", s.loop_candidates},
          {"loop_candidates_rejected", rejected}};
}

Json optimisationJson(const MapServerStats& s) {
  return {{"optimizations", s.optimizations},
          {"graph_solves", s.graph_solves},
          {"graph_solves_skipped", s.graph_solves_skipped},
          {"graph_merges_aligned", s.graph_merges_aligned},
          {"graph_solves_local", s.graph_solves_local},
          {"graph_solves_local_refused", s.graph_solves_local_refused},
          {"bundle_adjustment", bundleAdjustmentJson(s.ba)},
          {"optimizations_for_heartbeats", s.optimizations_for_heartbeats},
          {"corrections_resent", s.corrections_resent}};
}

Json intakeJson(const MapServerStats& s) {
  return {{"messages_rejected", s.inbox.messages_rejected},
          {"refusal_notices_sent", s.inbox.refusal_notices_sent},
          {"keyframe_acks_repeated", s.inbox.keyframe_acks_repeated},
          {"keyframes_waiting", s.keyframes_waiting},
          {"keyframes_deferred_max", s.keyframes_deferred_max},
          {"keyframes_held_for_hello", s.hello_hold.keyframes_held},
          {"keyframes_hold_dropped", s.hello_hold.keyframes_dropped},
          {"keyframes_queue_full", s.inbox.keyframes_dropped_queue_full},
          {"keyframes_duplicates_queued", s.inbox.keyframes_duplicates_queued},
          {"keyframes_throttled", s.inbox.keyframes_throttled},
          {"keyframes_features_extracted", s.keyframes_features_extracted}};
}

Json timesJson(const MapServerStats& s) {  // per keyframe, from dequeue to the graph update
  return {{"ingest_ms_median", jsonNumber(s.ingest_ms_median)},
          {"ingest_ms_p90", jsonNumber(s.ingest_ms_p90)},
          {"ingest_cpu_ms_median", jsonNumber(s.ingest_cpu_ms_median)},
          {"decode_cpu_ms_median", jsonNumber(s.decode_cpu_ms_median)}};  // the decode thread's
}

Json occupancyJson(const MapServerStats& s) {
  return {{"octree_leaves", s.map_leaves},
          {"octree_occupied_leaves", s.map_occupied_leaves},
          {"octree_memory_bytes", s.map_tree_memory_bytes},
          {"octree_rebuilds", s.map_rebuilds},
          {"slices_sent", s.slices_sent}};
}

Json storeJson(const MapServerStats& s) {
  return {{"store_state", s.store_failed ? "failed" : "ok"},
          {"store_failures", s.store_failures},
          {"store_recoveries", s.store_recoveries},
          {"keyframes_unacked_store_failed", s.keyframes_unacked_store_failed}};
}

Json rejectsJson(const MapServerStats& s) {
  Json by_robot = Json::object(), unknown = Json::object();
  for (const msg::RejectCount& r : s.inbox.rejects)
    (r.robot_id.empty() ? unknown : by_robot[r.robot_id])[r.reason] = r.count;
  return {{"rejects_by_robot", by_robot},       // claimed robot -> reason -> count (known robots)
          {"rejects_unknown_robot", unknown}};  // reason -> count for every other claimed sender
}

}  // namespace

Json serverRobotStatsJson(const ServerRobotStats& r) {
  return {{"robot", r.robot_id},
          {"keyframes", r.keyframes},
          {"sessions", r.sessions},
          {"loops_accepted", r.loops},
          {"map_id", r.map_id},
          {"merged", r.merged},
          {"bytes_received", r.bytes_received},
          {"bytes_sent", r.bytes_sent},
          {"refused", r.keyframes_refused},
          {"duplicates", r.duplicates},
          {"out_of_order", r.out_of_order},
          {"chain_splits", r.chain_splits},
          {"waiting", r.keyframes_waiting},
          {"before_hello", r.waiting_for_hello},
          {"queue_full", r.queue_full},
          {"duplicates_queued", r.duplicates_queued},
          {"throttled", r.throttled},
          {"refused_before_decode", r.refused_before_decode},
          {"mode", r.mode},
          {"placed", r.placed},
          {"first_placement_s", jsonNumber(r.first_placement_s)},
          {"keyframes_localized", r.keyframes_localized},
          {"keyframes_matched", r.keyframes_matched}};
}

Json serverStatsJson(const MapServerStats& s, const std::vector<std::vector<std::string>>& merged_maps) {
  Json j = {{"keyframes", s.keyframes},
            {"maps", s.maps},
            {"merged_maps", merged_maps},
            {"keyframes_localized", s.keyframes_localized}};
  for (const Json& part : {loopsJson(s), optimisationJson(s), intakeJson(s), timesJson(s), occupancyJson(s),
                           storeJson(s), rejectsJson(s)})
    j.update(part);
  Json robots = Json::array();
  for (const ServerRobotStats& r : s.robots) robots.push_back(serverRobotStatsJson(r));
  j["robots"] = std::move(robots);
  return j;
}

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
