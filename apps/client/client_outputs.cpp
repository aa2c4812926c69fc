#include "client_outputs.hpp"

#include <cstdio>
#include <fstream>

#include "rgbdmap/common/text_lines.hpp"
namespace rgbdmap::app {
namespace {

std::string field(const char* name, const std::string& value, bool last = false) {
  return std::string("  \"") + name + "\": " + value + (last ? "\n" : ",\n");
}
std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}
std::string flag(bool b) { return b ? "true" : "false"; }

}  // namespace

std::string clientJson(const ClientRunInfo& info, const RobotRunResult& r) {
  const RobotLinkStats& l = r.link;
  std::string s = "{\n";
  s += field("robot_id", jsonString(info.robot_id));
  s += field("dataset", jsonString(info.dataset));
  s += field("transport", jsonString(info.transport_url));
  s += field("signed", flag(info.signed_messages));
  s += field("frames", std::to_string(r.frames));
  s += field("keyframes", std::to_string(r.keyframes));
  s += field("tracking_losses", std::to_string(r.losses));
  s += field("segments", std::to_string(r.segments));
  s += field("unreadable_frames", std::to_string(r.unreadable_frames));
  s += field("ms_per_frame_median", number(r.medianMs()));
  s += field("wall_s", number(r.wall_s));
  s += field("interrupted", flag(r.interrupted));
  s += field("keyframes_sent", std::to_string(l.keyframes_sent));
  s += field("keyframes_not_sent", std::to_string(r.keyframes_not_sent));
  s += field("keyframes_acked", std::to_string(l.keyframes_acked));
  s += field("keyframes_refused", std::to_string(l.keyframes_refused));
  s += field("keyframes_given_up", std::to_string(l.keyframes_given_up));
  s += field("keyframes_pending", std::to_string(l.keyframes_pending));
  s += field("retransmissions", std::to_string(l.retransmissions));
  s += field("all_acked", flag(r.all_acked));
  s += field("corrections_received", std::to_string(l.corrections_received));
  s += field("graph_revision", std::to_string(l.graph_revision));
  s += field("final_correction_received", flag(r.final_correction_received));
  s += field("slices_received", std::to_string(l.slices_received));
  s += field("commands_received", std::to_string(l.commands_received));
  s += field("messages_rejected", std::to_string(l.messages_rejected));
  s += field("bytes_sent", std::to_string(l.bytes_sent));
  s += field("bytes_received", std::to_string(l.bytes_received), true);
  return s + "}\n";
}

std::string clientSummary(const RobotRunResult& r) {
  const RobotLinkStats& l = r.link;
  char buf[768];
  std::snprintf(buf, sizeof buf,
                "frames %d, keyframes %d (sent %llu, acked %llu, refused %llu, given up %llu, not sent %d), "
                "retransmissions %llu\ntracking losses %d, segments %d, unreadable %d, ms/frame median %.2f, "
                "wall %.1f s%s\ncorrections %llu (graph revision %lld, covering the last keyframe: %s), "
                "rejected %llu, sent %.1f KB, received %.1f KB",
                r.frames, r.keyframes, static_cast<unsigned long long>(l.keyframes_sent),
                static_cast<unsigned long long>(l.keyframes_acked),
                static_cast<unsigned long long>(l.keyframes_refused),
                static_cast<unsigned long long>(l.keyframes_given_up), r.keyframes_not_sent,
                static_cast<unsigned long long>(l.retransmissions), r.losses, r.segments, r.unreadable_frames,
                r.medianMs(), r.wall_s, r.interrupted ? " (interrupted)" : "",
                static_cast<unsigned long long>(l.corrections_received),
                static_cast<long long>(l.graph_revision), r.final_correction_received ? "yes" : "no",
                static_cast<unsigned long long>(l.messages_rejected), l.bytes_sent / 1e3,
                l.bytes_received / 1e3);
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
           ", every frame in the map frame (final corrections, re-anchored on reference keyframes)"},
      {base + "trajectory_" + R + "_live.txt", &r.live,
       "robot " + R + ", every frame as known live (map frame)"},
      {base + "keyframes_" + R + ".txt", &r.keyframes_final,
       "robot " + R + ", keyframes, final corrected (map frame)"},
  };
  for (const auto& f : files)
    if (Status s = writeTumTrajectory(f.path, *f.trajectory, f.what); !s) return s;
  const std::string json_path = base + "client_" + R + ".json";
  std::ofstream json(json_path);
  json << clientJson(info, r);
  if (!json) return Status::failure("cannot write " + json_path);
  return Status::success();
}

}  // namespace rgbdmap::app
