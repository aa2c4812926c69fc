#include "client_outputs.hpp"

#include <sys/resource.h>

#include <cstdio>

#include "rgbdmap/link/delivery_report.hpp"

namespace rgbdmap::app {

namespace {

/// The process's peak resident memory (getrusage ru_maxrss), MiB.
double peakRssMb() {
  struct rusage usage {};
  return ::getrusage(RUSAGE_SELF, &usage) == 0 ? usage.ru_maxrss / 1024.0 : 0.0;
}

/// "\nspool: ..." with a keyframe spool, else "".
std::string spoolSummary(const RobotLinkStats& l) {
  if (l.keyframes_spooled + l.spool_recovered + l.keyframes_live_only == 0) return "";
  return "\nspool: " + std::to_string(l.spool_depth) + " keyframes left for the next start, " +
         std::to_string(l.spool_recovered) + " found at start (" + std::to_string(l.recovered_acked) +
         " acked since), " + std::to_string(l.keyframes_live_only) + " sent live only, " +
         std::to_string(l.spool_damaged) + " damaged";
}

/// [[keyframe id, wall-clock us of its accepting ack], ...]: deploy/bench_viewer.sh times ack -> voxels.
Json ackTimesJson(const std::map<int, int64_t>& ack_utime) {
  Json list = Json::array();
  for (const auto& [id, utime] : ack_utime) list.push_back({id, utime});
  return list;
}

}  // namespace

Json clientJson(const ClientRunInfo& info, const RobotRunResult& r) {
  const RobotLinkStats& l = r.link;
  return {{"robot_id", info.robot_id},
          {"dataset", info.dataset},
          {"transport", info.transport_url},
          {"signed", info.signed_messages},
          {"frames", r.frames},
          {"keyframes", r.keyframes},
          {"tracking_losses", r.losses},
          {"segments", r.segments},
          {"unreadable_frames", r.unreadable_frames},
          {"dropped_frames", r.dropped_frames},
          {"source_error", r.source_error},
          {"ms_per_frame_median", jsonNumber(r.medianMs())},
          {"wall_s", jsonNumber(r.wall_s)},
          {"interrupted", r.interrupted},
          {"keyframes_sent", l.keyframes_sent},
          {"keyframes_not_sent", r.keyframes_not_sent},
          {"keyframes_acked", l.keyframes_acked},
          {"keyframes_refused", l.keyframes_refused},
          {"keyframes_given_up", l.keyframes_given_up},
          {"keyframes_pending", l.keyframes_pending},
          {"retransmissions", l.retransmissions},
          {"rtt_samples", l.rtt_samples},
          {"srtt_ms", jsonNumber(l.srtt_ms)},
          {"rttvar_ms", jsonNumber(l.rttvar_ms)},
          {"rto_ms", jsonNumber(l.rto_ms)},
          {"ack_latency_ms_median", jsonNumber(l.ack_latency_ms_median)},
          {"ack_latency_ms_p90", jsonNumber(l.ack_latency_ms_p90)},
          {"ack_latency_ms_max", jsonNumber(l.ack_latency_ms_max)},
          {"all_acked", r.all_acked},
          {"keyframes_not_accepted", deliveryReport(r).unaccepted},
          {"keyframes_lost", deliveryReport(r).lost},
          {"keyframes_spooled", l.keyframes_spooled},
          {"keyframes_live_only", l.keyframes_live_only},
          {"keyframes_requeued", l.keyframes_requeued},
          {"sends_held_unmatched", l.sends_held_unmatched},
          {"subscriber_matches", l.subscriber_matches},
          {"spool_depth", l.spool_depth},
          {"spool_bytes", l.spool_bytes},
          {"spool_recovered", l.spool_recovered},
          {"spool_recovered_acked", l.recovered_acked},
          {"spool_recovered_refused", l.recovered_refused},
          {"spool_damaged", l.spool_damaged},
          {"spool_oldest_utime", l.spool_oldest_utime},
          {"server_heard", l.server_heard},
          {"refused_by_reason", l.refused_by_reason},
          {"corrections_received", l.corrections_received},
          {"graph_revision", l.graph_revision},
          {"final_correction_received", r.final_correction_received},
          {"slices_received", l.slices_received},
          {"commands_received", l.commands_received},
          {"messages_rejected", l.messages_rejected},
          {"bytes_sent", l.bytes_sent},
          {"bytes_received", l.bytes_received},
          {"rss_peak_mb", jsonNumber(peakRssMb())},
          {"keyframe_ack_utime", ackTimesJson(r.keyframe_ack_utime)}};
}

std::string clientSummary(const RobotRunResult& r) {
  const RobotLinkStats& l = r.link;
  char buf[1024];
  std::snprintf(buf, sizeof buf,
                "frames %d, keyframes %d (sent %llu, acked %llu, refused %llu, given up %llu, not sent %d), "
                "retransmissions %llu\ntracking losses %d, segments %d, unreadable %d, dropped %d, ms/frame "
                "median %.2f, "
                "wall %.1f s%s\ncorrections %llu (graph revision %lld, covering the last keyframe: %s), "
                "rejected %llu, sent %.1f KB, received %.1f KB%s",
                r.frames, r.keyframes, static_cast<unsigned long long>(l.keyframes_sent),
                static_cast<unsigned long long>(l.keyframes_acked),
                static_cast<unsigned long long>(l.keyframes_refused),
                static_cast<unsigned long long>(l.keyframes_given_up), r.keyframes_not_sent,
                static_cast<unsigned long long>(l.retransmissions), r.losses, r.segments, r.unreadable_frames,
                r.dropped_frames, r.medianMs(), r.wall_s, r.interrupted ? " (interrupted)" : "",
                static_cast<unsigned long long>(l.corrections_received),
                static_cast<long long>(l.graph_revision), r.final_correction_received ? "yes" : "no",
                static_cast<unsigned long long>(l.messages_rejected), l.bytes_sent / 1e3,
                l.bytes_received / 1e3, spoolSummary(l).c_str());
  return buf;
}

Status writeClientOutputs(const std::string& out_dir, const ClientRunInfo& info, const RobotRunResult& r) {
  const std::string base = out_dir + "/";
  const std::string R = info.robot_id;
  const struct {
    std::string path;
    const Trajectory* trajectory;
    std::string what;
  } files[] = {
      {base + "trajectory_" + R + ".txt", &r.final_map,
       "robot " + R +
           ", every frame in the map frame (final corrections, re-anchored on reference keyframes, "
           "smoothed)"},
      {base + "trajectory_" + R + "_live.txt", &r.live,
       "robot " + R + ", every frame as known live (map frame)"},
      {base + "keyframes_" + R + ".txt", &r.keyframes_final,
       "robot " + R + ", keyframes, final corrected (map frame)"},
  };
  for (const auto& f : files)
    if (Status s = writeTumTrajectory(f.path, *f.trajectory, f.what); !s) return s;
  return writeJsonFile(base + "client_" + R + ".json", clientJson(info, r));
}

}  // namespace rgbdmap::app
