#include "run_report.hpp"

#include <algorithm>
#include <cstdio>
#include <tuple>
#include <utility>

#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/server/stats_json.hpp"

namespace rgbdmap::cmd {
namespace {

std::string num(double v, const char* fmt = "%.6g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

Json ateOrNull(const std::optional<AteResult>& ate) { return ate ? jsonNumber(ate->rmse) : Json(); }

/// One alignment for all robots' frames (same dataset), each timestamp once.
std::optional<AteResult> jointAte(const Trajectory& ground_truth, Trajectory estimate) {
  std::sort(estimate.begin(), estimate.end(),
            [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
  Trajectory distinct;
  for (const StampedPose& p : estimate)
    if (distinct.empty() || p.timestamp > distinct.back().timestamp + 1e-9) distinct.push_back(p);
  if (auto a = computeAte(ground_truth, distinct)) return *a;
  return std::nullopt;
}

/// The server's figures (serverStatsJson, the keys of server_summary.json) and the run's evaluation.
Json serverJson(const MapServerStats& s, const ServerOutcome& server, size_t robot_count) {
  Json j = serverStatsJson(s, server.maps);
  j["merged"] = server.maps.size() == 1 && robot_count > 1;
  j["joint_ate_rmse_m"] = ateOrNull(server.joint);
  return j;
}

Json robotJson(const RunOptions& o, const RobotPlan& plan, const RobotOutcome& robot,
               const MapServerStats& s) {
  const RobotRunResult& r = robot.result;
  const RobotLinkStats& l = r.link;
  const ServerRobotStats* sr = nullptr;
  for (const ServerRobotStats& x : s.robots)
    if (x.robot_id == plan.id) sr = &x;
  const auto per_kf = [&](uint64_t bytes) {
    return l.keyframes_sent ? static_cast<double>(bytes) / static_cast<double>(l.keyframes_sent) : 0.0;
  };
  const double bytes_per_kf = per_kf(l.bytes_sent);
  return {{"dataset", o.datasets[plan.dataset]},
          {"frame_range", {plan.first, plan.end}},
          {"frames", r.frames},
          {"unreadable_frames", r.unreadable_frames},
          {"keyframes", r.keyframes},
          {"keyframes_acked", l.keyframes_acked},
          {"keyframes_stored_by_server", sr ? sr->keyframes : 0},
          {"loops_accepted", sr ? sr->loops : 0},
          {"tracking_losses", r.losses},
          {"ate_rmse_m", ateOrNull(robot.ate)},
          {"ate_rmse_odometry_only_m", ateOrNull(robot.ate_odometry)},
          {"client_ms_per_frame_median", jsonNumber(r.medianMs())},
          {"waited_for_server", r.waited_for_server},
          {"bytes_per_keyframe_mean", jsonNumber(bytes_per_kf)},
          // The parts of a keyframe; bytes_per_keyframe_mean is all the link sent (envelopes, other fields,
          // retransmissions, heartbeats, poses) over the keyframes sent.
          {"keyframe_message_bytes_mean", jsonNumber(per_kf(l.keyframe_message_bytes))},
          {"keyframe_part_bytes_mean",
           {{"depth", jsonNumber(per_kf(l.keyframe_depth_bytes))},
            {"colour", jsonNumber(per_kf(l.keyframe_color_bytes))},
            {"features", jsonNumber(per_kf(l.keyframe_feature_bytes))}}},
          {"uplink_kbit_per_s",
           jsonNumber(r.wall_s > 0 ? 8e-3 * static_cast<double>(l.bytes_sent) / r.wall_s : 0.0)},
          {"bytes_sent", l.bytes_sent},
          {"bytes_received", l.bytes_received},
          {"retransmissions", l.retransmissions},
          {"srtt_ms", jsonNumber(l.srtt_ms)},
          {"rto_ms", jsonNumber(l.rto_ms)},
          {"corrections_received", l.corrections_received}};
}

}  // namespace

void evaluateRun(const std::vector<TumDataset>& datasets, const std::vector<RobotPlan>& plans,
                 std::vector<RobotOutcome>* robots, ServerOutcome* server) {
  Trajectory joint_estimate;
  for (size_t i = 0; i < plans.size(); ++i) {
    RobotOutcome& r = (*robots)[i];
    const auto& gt = datasets[plans[i].dataset].groundTruth();
    if (!gt) continue;
    if (auto a = computeAte(*gt, r.result.final_map)) r.ate = *a;
    if (auto a = computeAte(*gt, r.result.odometry)) r.ate_odometry = *a;
    if (datasets.size() == 1)
      joint_estimate.insert(joint_estimate.end(), r.result.final_map.begin(), r.result.final_map.end());
  }
  if (!joint_estimate.empty() && plans.size() > 1)
    server->joint = jointAte(*datasets[0].groundTruth(), std::move(joint_estimate));
}

Status writeTrajectories(const std::string& out_dir, const std::vector<RobotPlan>& plans,
                         const std::vector<RobotOutcome>& robots,
                         const std::vector<ServerKeyframe>& keyframes) {
  for (size_t i = 0; i < plans.size(); ++i) {
    const std::string& id = plans[i].id;
    Trajectory optimised;
    for (const ServerKeyframe& k : keyframes)
      if (k.robot_id == id) optimised.push_back({k.timestamp, k.T_map_kf});
    for (const auto& [name, trajectory, what] :
         {std::tuple{"/trajectory_", &robots[i].result.final_map, "every frame"},
          std::tuple{"/keyframes_", &std::as_const(optimised), "optimised keyframes"}}) {
      const std::string header = std::string("rgbdmap run, ") + id + ", " + what + ", map frame";
      if (const Status s = writeTumTrajectory(out_dir + name + id + ".txt", *trajectory, header); !s)
        return s;
    }
  }
  return Status::success();
}

Json reportJson(const RunOptions& o, const std::vector<RobotPlan>& plans,
                const std::vector<RobotOutcome>& robots, const ServerOutcome& server) {
  Json per_robot = Json::object();
  for (size_t i = 0; i < plans.size(); ++i)
    per_robot[plans[i].id] = robotJson(o, plans[i], robots[i], server.stats);
  return {{"mode", "slam"},
          {"transport", o.transport},
          {"datasets", o.datasets},
          {"wall_s", jsonNumber(server.wall_s)},
          {"server", serverJson(server.stats, server, plans.size())},
          {"robots", per_robot}};
}

void printRunSummary(const RunOptions& o, const std::string& url, const std::vector<RobotPlan>& plans,
                     const std::vector<RobotOutcome>& robots, const ServerOutcome& server) {
  const MapServerStats& stats = server.stats;
  std::fprintf(stderr, "rgbdmap run: %zu robot(s) over %s, %.1f s (and %.1f s before it: %s)\n", plans.size(),
               url.c_str(), server.wall_s, server.prepare_s, server.prepare_what.c_str());
  for (size_t i = 0; i < plans.size(); ++i) {
    const RobotOutcome& r = robots[i];
    std::fprintf(
        stderr,
        "  %s frames %d-%d (%d unreadable): %d keyframes (%llu acked), ATE %s m (odometry alone %s m), "
        "%.1f ms/frame\n",
        plans[i].id.c_str(), plans[i].first, plans[i].end, r.result.unreadable_frames, r.result.keyframes,
        static_cast<unsigned long long>(r.result.link.keyframes_acked),
        r.ate ? num(r.ate->rmse, "%.4f").c_str() : "n/a",
        r.ate_odometry ? num(r.ate_odometry->rmse, "%.4f").c_str() : "n/a", r.result.medianMs());
  }
  std::fprintf(
      stderr, "  server: %d keyframes, %d loops (%d rejected by the graph), %zu map(s)%s, %.1f ms/keyframe\n",
      stats.keyframes, stats.loops_accepted, stats.loops_disabled, server.maps.size(),
      server.joint ? (", joint ATE " + num(server.joint->rmse, "%.4f") + " m").c_str() : "",
      stats.ingest_ms_median);
  std::fprintf(
      stderr,
      "  map: %zu octree leaves (%zu occupied), %.1f MB in memory, %llu rebuild(s), %llu slices sent\n",
      static_cast<size_t>(stats.map_leaves), static_cast<size_t>(stats.map_occupied_leaves),
      stats.map_tree_memory_bytes / 1e6, static_cast<unsigned long long>(stats.map_rebuilds),
      static_cast<unsigned long long>(stats.slices_sent));
  const std::string map = o.map.empty()  ? ", map/"
                          : o.frozen_map ? "; the map " + o.map + " is unchanged"
                                         : "; the map " + o.map + " extended";
  std::fprintf(
      stderr,
      "wrote %s/: trajectory_<robot>.txt, keyframes_<robot>.txt, report.json, map.png, map.bt, map.ot, "
      "map.ply, slice_<robot>.pgm/.yaml, map_<id>.pgm/.yaml (the 2-D map of each map)%s\n",
      o.out.c_str(), map.c_str());
}

}  // namespace rgbdmap::cmd
