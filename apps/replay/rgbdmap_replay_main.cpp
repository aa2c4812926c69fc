// rgbdmap-replay: a light robot for scale tests. Sends a recorded keyframe stream (rgbdmap-client
// --record-keyframes) to the mapping server as robot R, at a set rate, in as many passes as a duration asks,
// and reports every keyframe's acknowledgement latency. No camera and no odometry: many of these fit on a
// machine that runs one odometry (deploy/bench_fleet.sh runs 16).
#include <sys/resource.h>

#include <cstdio>
#include <exception>
#include <filesystem>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/odometry_setup.hpp"
#include "rgbdmap/cli/signal_thread.hpp"
#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/link/keyframe_replay.hpp"
#include "rgbdmap/link/robot_client_config.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::app {
namespace {

const char* kUsage =
    "usage: rgbdmap-replay --stream FILE [--config FILE] [--robot-id R] [options]\n"
    "Sends a recorded keyframe stream (rgbdmap-client --record-keyframes) to the mapping server as robot R:\n"
    "its Hello, heartbeats and keyframes, signed with R's key, resent until acknowledged. After the first "
    "pass\n"
    "(from keyframe --start) the whole stream is sent again, with new keyframe ids and a new segment each\n"
    "pass, until --duration is over. Writes --out/replay_R.json (every keyframe's acknowledgement latency,\n"
    "its quantiles overall and per minute).\n"
    "  --stream FILE      the recorded keyframe stream (its Hello gives the camera and mount)\n"
    "  --config FILE      YAML: robot, transport, link (deploy/config/client.yaml); camera, dataset and\n"
    "                     odometry sections are ignored\n"
    "  --robot-id R       overrides robot.id\n"
    "  --transport URL    overrides transport.url\n"
    "  --rate HZ          keyframes per second (default: the recording's own timestamps)\n"
    "  --duration S       seconds of sending, in passes (default: one pass)\n"
    "  --start K          the first pass begins at keyframe K of the stream (default 0)\n"
    "  --phase P          the first pass begins at keyframe floor(P * K) of a stream of K (0 <= P < 1)\n"
    "  --out DIR          output folder (default: out)\n"
    "  --spool DIR        keep every keyframe in a keyframe spool DIR/R until acknowledged "
    "(robot.spool_max_mb;\n"
    "                     default: none); a new start sends what an earlier one left first\n"
    "Exit status: 0 every keyframe acknowledged; 1 run-time error; 2 usage or configuration error;\n"
    "3 keyframes not acknowledged.\n";

Json report(const std::string& robot, const std::string& stream_path, const ReplayResult& r) {
  Json j;
  j["robot"] = robot;
  j["stream"] = stream_path;
  j["keyframes_sent"] = r.keyframes.size();
  j["keyframes_acked"] = r.acked();
  j["send_failures"] = r.send_failures;
  j["all_acked"] = r.send_failures == 0 && r.acked() == r.keyframes.size() && !r.keyframes.empty();
  j["passes"] = r.passes;
  j["stopped"] = r.stopped;
  j["wall_s"] = jsonNumber(r.wall_s, 4);
  j["spool_depth"] = r.link.spool_depth;
  j["spool_recovered"] = r.link.spool_recovered;
  j["keyframes_live_only"] = r.link.keyframes_live_only;
  j["keyframes_requeued"] = r.link.keyframes_requeued;
  j["retransmissions"] = r.link.retransmissions;
  j["bytes_sent"] = r.link.bytes_sent;
  struct rusage usage {};
  j["rss_peak_mb"] = jsonNumber(::getrusage(RUSAGE_SELF, &usage) == 0 ? usage.ru_maxrss / 1024.0 : 0.0, 4);
  j["ack_ms_p50"] = jsonNumber(r.ackQuantileMs(0.5), 4);
  j["ack_ms_p90"] = jsonNumber(r.ackQuantileMs(0.9), 4);
  j["ack_ms_max"] = jsonNumber(r.ackQuantileMs(1.0), 4);
  Json minutes = Json::array();
  const double last_s = r.keyframes.empty() ? 0.0 : r.keyframes.back().sent_s;
  for (int m = 0; m * 60.0 <= last_s; ++m)
    minutes.push_back({{"minute", m},
                       {"ack_ms_p50", jsonNumber(r.ackQuantileMs(0.5, m * 60.0, (m + 1) * 60.0), 4)},
                       {"ack_ms_p90", jsonNumber(r.ackQuantileMs(0.9, m * 60.0, (m + 1) * 60.0), 4)}});
  j["per_minute"] = minutes;
  Json kfs = Json::array();
  for (const ReplayedKeyframe& k : r.keyframes)
    kfs.push_back({k.id, jsonNumber(k.sent_s, 6), jsonNumber(k.ack_ms, 5)});
  j["keyframes"] = kfs;  // [id, sent_s, ack_ms (-1: not acknowledged)]
  return j;
}

/// --rate, --duration, --start, --phase: the replay's pace and where in the stream it begins.
ReplayOptions parseReplayOptions(cli::Args& args, double* phase, std::vector<std::string>* errors) {
  ReplayOptions ro;
  ro.rate_hz = args.getDouble("rate").value_or(0.0);
  ro.duration_s = args.getDouble("duration").value_or(0.0);
  const long long start = args.getInt("start").value_or(0);
  if (!(ro.rate_hz >= 0.0 && ro.rate_hz <= 1000.0)) errors->push_back("--rate must be in [0, 1000]");
  if (!(ro.duration_s >= 0.0 && ro.duration_s <= 7 * 86400.0))
    errors->push_back("--duration must be in [0, 604800]");
  if (start < 0 || start > 100000000) errors->push_back("--start must be in [0, 1e8]");
  ro.start = static_cast<size_t>(start);
  *phase = args.getDouble("phase").value_or(0.0);
  if (!(*phase >= 0.0 && *phase < 1.0)) errors->push_back("--phase must be in [0, 1)");
  if (args.has("phase") && args.has("start")) errors->push_back("--phase and --start exclude each other");
  return ro;
}

/// The robot's configuration file (its camera:, dataset: and odometry: sections are not used here), the
/// command line's overrides and the robot's key.
RobotClientConfig readReplayConfig(cli::Args& args, std::vector<std::string>* errors) {
  RobotClientConfig config;
  const std::string config_path = args.getOr("config", "");
  if (!config_path.empty()) {
    if (auto reader = ConfigReader::fromFile(config_path)) {
      readRobotClientConfig(*reader, &config);
      for (const std::string& e : reader->errors())
        if (e.find("unknown key 'camera.") == std::string::npos &&
            e.find("unknown key 'dataset.") == std::string::npos &&
            e.find("unknown key 'odometry.") == std::string::npos)
          errors->push_back(e);
    } else {
      errors->push_back(reader.error());
    }
  }
  config.robot_id = args.getOr("robot-id", config.robot_id);
  config.transport_url = args.getOr("transport", config.transport_url);
  if (const Status s = transport::checkTransportUrl(config.transport_url); !s) errors->push_back(s.error());
  if (!config.key_file.empty()) {
    if (auto key = readKeyFile(config.key_file, std::filesystem::path(config_path).parent_path().string()))
      config.link.key = *key;
    else
      errors->push_back(key.error());
  }
  return config;
}

/// Writes replay_<robot>.json and the summary line; the exit code (3: keyframes not acknowledged).
int finish(const RobotClientConfig& config, const std::string& stream_path, const std::string& out,
           const ReplayResult& result) {
  const std::string json_path = out + "/replay_" + config.robot_id + ".json";
  if (Status s = writeJsonFile(json_path, report(config.robot_id, stream_path, result)); !s)
    return log::error(s.error()), 1;
  std::fprintf(stderr,
               "robot %s: %zu keyframes sent in %zu pass(es), %zu acknowledged; ack p50 %.0f ms, p90 %.0f "
               "ms, max %.0f ms; wrote %s\n",
               config.robot_id.c_str(), result.keyframes.size(), result.passes, result.acked(),
               result.ackQuantileMs(0.5), result.ackQuantileMs(0.9), result.ackQuantileMs(1.0),
               json_path.c_str());
  if (result.keyframes.empty() || result.acked() < result.keyframes.size() || result.send_failures > 0)
    return log::error("robot ", config.robot_id, ": ",
                      result.keyframes.size() + result.send_failures - result.acked(),
                      " keyframes not acknowledged"),
           3;
  return 0;
}

/// Sends the stream over the link until it is done or a signal stops it.
ReplayResult replayOverLink(const KeyframeStream& stream, RobotClientConfig& config, ReplayOptions ro,
                            cli::SignalThread& signals, Status* started) {
  auto transport = transport::makeTransport(config.transport_url);
  if (!transport) {
    *started = Status::failure("transport " + config.transport_url + ": " + transport.error());
    return {};
  }
  config.link.chunk_bytes = resolveChunkBytes(config.link.chunk_bytes, config.transport_url);
  RobotLink link(**transport, config.link);
  if (*started = link.start(); !*started) return {};
  StopRequest stop;
  signals.start([&stop](int sig) {
    log::warn("signal ", sig, ": stopping (again to quit at once); the report will still be written");
    stop.request();
  });
  ro.stop = &stop;
  ro.final_wait_s = config.final_wait_s;
  const ReplayResult result = replayKeyframes(stream, link, ro);
  link.stop();
  (*transport)->stop();
  return result;
}

int run(int argc, char** argv) {
  cli::Args args(argc, argv, {"help"});
  if (args.has("help")) return std::printf("%s", kUsage), 0;
  cli::SignalThread signals;
  args.checkAllowed({"stream", "config", "robot-id", "transport", "rate", "duration", "start", "phase", "out",
                     "spool", "log-level", "help"});
  std::vector<std::string> errors;
  cli::applyLogLevel(args, &errors);
  const std::string stream_path = args.getOr("stream", "");
  if (stream_path.empty()) errors.push_back("--stream FILE is required");
  double phase = 0.0;
  ReplayOptions ro = parseReplayOptions(args, &phase, &errors);
  for (const auto& p : args.positional()) errors.push_back("unexpected argument '" + p + "'");
  errors.insert(errors.begin(), args.errors().begin(), args.errors().end());
  RobotClientConfig config = readReplayConfig(args, &errors);
  if (!errors.empty()) return cli::usageError(errors, kUsage);

  Result<KeyframeStream> stream = readKeyframeStream(stream_path);
  if (!stream) return log::error(stream.error()), 1;
  if (args.has("phase"))
    ro.start = static_cast<size_t>(phase * static_cast<double>(stream->keyframes.size()));
  config.link.robot_id = config.robot_id;
  config.link.camera = stream->hello.camera;
  config.link.T_base_camera = stream->hello.T_base_camera;
  config.link.software_version = "rgbdmap-replay 0.1.0";
  if (const std::string e = config.link.validate(); !e.empty()) return cli::usageError({e}, kUsage);
  const std::string out = args.getOr("out", "out");
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) return log::error("cannot create ", out, ": ", ec.message()), 1;

  if (const std::string spool_dir = args.getOr("spool", ""); !spool_dir.empty()) {
    auto spool = KeyframeSpool::open(
        {(std::filesystem::path(spool_dir) / config.robot_id).string(), uint64_t(config.spool_max_mb) << 20},
        config.robot_id);
    if (!spool) return log::error(spool.error()), 1;
    ro.first_keyframe_id = (*spool)->firstKeyframeId();
    ro.first_segment = (*spool)->firstSegment();
    config.link.spool = std::move(*spool);
  }
  log::info("robot ", config.robot_id, " replays ", stream->keyframes.size(), " keyframes of ",
            stream->hello.robot_id, " from ", stream_path, " on ", config.transport_url);
  Status started = Status::success();
  const ReplayResult result = replayOverLink(*stream, config, ro, signals, &started);
  if (!started) return log::error(started.error()), 1;
  return finish(config, stream_path, out, result);
}

}  // namespace
}  // namespace rgbdmap::app

int main(int argc, char** argv) {
  try {
    return rgbdmap::app::run(argc - 1, argv + 1);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rgbdmap-replay: unexpected error: %s\n", e.what());
    return 1;
  }
}
