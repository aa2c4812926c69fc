// rgbdmap-client: the robot program. Runs the visual odometry on a frame source (a TUM folder or a ROS bag at
// its frame rate or --fast, a live camera at the camera's),
// sends keyframes to the mapping server, applies its corrections, and writes the trajectory in the map frame.

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>

#include <opencv2/core.hpp>

#include "client_outputs.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/odometry_setup.hpp"
#include "rgbdmap/cli/progress.hpp"
#include "rgbdmap/cli/signal_thread.hpp"
#include "rgbdmap/cli/source_setup.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/link/delivery_report.hpp"
#include "rgbdmap/link/keyframe_spool.hpp"
#include "rgbdmap/link/keyframe_stream.hpp"
#include "rgbdmap/link/robot_client_config.hpp"
#include "rgbdmap/source/frame_recorder.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::app {
namespace {

const char* kUsage =
    "usage: rgbdmap-client (--dataset DIR | --source URL) [--config FILE] [--robot-id R] [options]\n"
    "Runs visual odometry on a TUM-layout dataset, a ROS bag or a live camera as robot R, sends keyframes to "
    "the mapping server, "
    "applies\n"
    "its pose corrections and writes into --out: trajectory_R.txt (every frame, map frame, final "
    "corrections),\n"
    "trajectory_R_live.txt (as known at each frame), keyframes_R.txt, client_R.json (counters, timings).\n"
    "  --config FILE           YAML: robot, transport, link (see deploy/config/client.yaml) and the camera,\n"
    "                          dataset and odometry sections of deploy/config/odometry.yaml\n"
    "  --dataset DIR           TUM layout: rgb.txt, depth.txt, rgb/, depth/ [, camera.yaml]; a 7-Scenes\n"
    "                          sequence folder reads as --source 7scenes:DIR\n"
    "  --robot-id R            overrides robot.id\n"
    "  --map-mode map|localize overrides robot.map_mode: localize places and tracks the robot in the "
    "server's\n"
    "                          stored map without changing it (its keyframes are not stored)\n"
    "  --key-file FILE         overrides robot.key_file (a path from the current folder, e.g. keys/R.key\n"
    "                          from `rgbdmap keys new R`)\n"
    "  --transport URL         overrides transport.url: memq:// | udpm://239.255.76.67:7667?ttl=0 |\n"
    "                          dds://?domain=0 (Cyclone DDS needs CYCLONEDDS_URI, e.g.\n"
    "                          CYCLONEDDS_URI=file://$PWD/deploy/dds/cyclonedds-loopback.xml)\n"
    "  --fast                  as fast as possible instead of the recording's frame rate (a live camera\n"
    "                          always runs at its own: the newest frame wins, missed ones are counted)\n"
    "  --record DIR            also write every frame the odometry consumed as a TUM-layout folder with\n"
    "                          camera.yaml (replay it with --dataset DIR)\n"
    "  --record-keyframes FILE also write every keyframe sent, as sent, into FILE (a keyframe stream for\n"
    "                          rgbdmap-replay; written at the end)\n"
    "  --frames A:B            frames A (inclusive) to B (exclusive); A: or :B leave one end open\n"
    "  --out DIR               output folder (default: out)\n"
    "  --spool DIR             keyframe spool folder (overrides robot.spool_dir; default <--out>/spool): "
    "every\n"
    "                          keyframe stays in DIR/R until the server acknowledges it; the next start "
    "sends\n"
    "                          what is left\n"
    "  --threads N             OpenCV threads (default 1)\n"
    "On SIGINT or SIGTERM the robot stops reading frames, waits up to link.final_wait_s for the server's\n"
    "answers and exits with the rest spooled (a second signal exits at once; the spool keeps them too).\n"
    "Exit status: 0 every keyframe accepted by the server or spooled for the next start; 1 run-time error\n"
    "(dataset, transport, spool); 2 usage or configuration error; 3 keyframes lost (refused by the server,\n"
    "or unanswered and not spooled) or no server heard at all (how many and why is printed).\n";

constexpr int kExitKeyframesNotAccepted = 3;

struct ClientArgs {
  std::optional<SourceUrl> source;
  std::string out = "out", record, record_keyframes, spool;
  int first_frame = 0, end_frame = -1, threads = 1;
  bool fast = false;
};

bool parseFrameRange(const std::string& text, int* first, int* end) {
  const auto colon = text.find(':');
  if (colon == std::string::npos) return false;
  auto parse = [](const std::string& s, int fallback, int* out) {
    if (s.empty()) return (*out = fallback), true;
    char* e = nullptr;
    const long v = std::strtol(s.c_str(), &e, 10);
    if (*e != '\0' || v < 0 || v > 100000000) return false;
    return (*out = static_cast<int>(v)), true;
  };
  return parse(text.substr(0, colon), 0, first) && parse(text.substr(colon + 1), -1, end) &&
         (*end < 0 || *end > *first);
}

ClientArgs parseArgs(cli::Args& args, std::vector<std::string>* errors) {
  ClientArgs a;
  a.source = sourceUrlArgument(args, errors, true);
  a.out = args.getOr("out", a.out);
  a.record = args.getOr("record", "");
  a.record_keyframes = args.getOr("record-keyframes", "");
  a.spool = args.getOr("spool", "");
  a.fast = args.has("fast");
  const long long threads = args.getInt("threads").value_or(1);
  if (threads < 1 || threads > 256) errors->push_back("--threads must be in [1, 256]");
  a.threads = static_cast<int>(threads);
  if (auto range = args.get("frames"); range && !parseFrameRange(*range, &a.first_frame, &a.end_frame))
    errors->push_back("--frames takes A:B with 0 <= A < B (either may be left out), not '" + *range + "'");
  for (const auto& p : args.positional()) errors->push_back("unexpected argument '" + p + "'");
  return a;
}

/// The whole configuration: --config sections, then command-line overrides; every problem in *errors.
/// The whole configuration and the source: --config sections, then command-line overrides; configuration
/// problems in *errors (exit 2), a source that cannot be opened as the failure (exit 1).
Result<OpenedSource> loadClientConfig(cli::Args& args, const ClientArgs& a, RobotClientConfig* config,
                                      std::vector<std::string>* errors) {
  RobotClientConfig& c = *config;
  const auto read_more = [&c](ConfigReader& r) { readRobotClientConfig(r, &c); };
  Result<OpenedSource> opened = Result<OpenedSource>::failure("");
  if (!errors->empty() || !a.source)
    addConfigErrors(args, a.source, errors, read_more);  // every error at once; nothing opened
  else
    opened =
        openSource(args, *a.source, {static_cast<size_t>(a.first_frame), static_cast<long long>(a.end_frame)},
                   errors, read_more);
  if (!opened && errors->empty()) return opened;  // the source cannot be opened (exit 1)
  c.robot_id = args.getOr("robot-id", c.robot_id);
  if (args.has("map-mode")) {
    const std::string mode = args.getOr("map-mode", "");
    if (mode != "map" && mode != "localize")
      errors->push_back("--map-mode must be map or localize, not '" + mode + "'");
    c.localize = mode == "localize";
    c.link.localize = c.localize;
  }
  const std::string config_folder = std::filesystem::path(args.getOr("config", "")).parent_path().string();
  if (!a.spool.empty())
    c.spool_dir = a.spool;
  else if (c.spool_dir.empty())
    c.spool_dir = (std::filesystem::path(a.out) / "spool").string();
  else if (std::filesystem::path(c.spool_dir).is_relative() && !config_folder.empty())
    c.spool_dir = (std::filesystem::path(config_folder) / c.spool_dir).string();
  c.transport_url = args.getOr("transport", c.transport_url);
  if (const Status s = transport::checkTransportUrl(c.transport_url); !s) errors->push_back(s.error());
  // robot.key_file is relative to the configuration file's folder, --key-file to the current folder.
  const std::string config_dir =
      args.has("key-file") ? "" : std::filesystem::path(args.getOr("config", "")).parent_path().string();
  c.key_file = args.getOr("key-file", c.key_file);
  if (!c.key_file.empty()) {
    if (auto key = readKeyFile(c.key_file, config_dir))
      c.link.key = *key;
    else
      errors->push_back(key.error());
  }
  c.link.robot_id = c.robot_id;
  if (opened) c.link.camera = opened->setup.camera;
  if (const std::string e = c.link.validate(); !e.empty()) errors->push_back(e);
  return opened;
}

/// The robot's keyframe spool (<spool_dir>/<robot id>), unless robot.spool_max_mb is 0.
Status openSpool(RobotClientConfig* config) {
  if (config->spool_max_mb == 0) return Status::success();
  KeyframeSpoolOptions options;
  options.directory = (std::filesystem::path(config->spool_dir) / config->robot_id).string();
  options.max_bytes = uint64_t(config->spool_max_mb) << 20;
  auto spool = KeyframeSpool::open(options, config->robot_id);
  if (!spool) return Status::failure(spool.error());
  const KeyframeSpoolStats s = (*spool)->stats();
  log::info("robot ", config->robot_id, ": keyframe spool ", options.directory, ": ", s.depth,
            " keyframes left by an earlier run",
            s.damaged ? ", " + std::to_string(s.damaged) + " damaged" : "",
            (*spool)->resumed() ? ", resuming session " + std::to_string((*spool)->session()) +
                                      " at keyframe id " + std::to_string((*spool)->firstKeyframeId())
                                : "");
  config->link.spool = std::move(*spool);
  return Status::success();
}

/// --record DIR: the frames the robot reads are also written as a TUM folder.
Status recordInto(const std::string& dir, const CameraIntrinsics& camera,
                  std::unique_ptr<FrameSource>* source, RecordingSource** recording) {
  if (dir.empty()) return Status::success();
  auto recorder = TumRecorder::create(dir, camera);
  if (!recorder) return Status::failure(recorder.error());
  auto wrapped = std::make_unique<RecordingSource>(std::move(*source), std::move(*recorder));
  *recording = wrapped.get();
  *source = std::move(wrapped);
  return Status::success();
}

/// Closes the --record folder and the --record-keyframes stream.
Status finishRecordings(const ClientArgs& a, RecordingSource* recording, KeyframeStreamWriter* keyframes) {
  if (recording) {
    if (Status s = recording->finish(); !s) return s;
    log::info("recorded ", recording->recorded(), " frames into ", a.record);
  }
  if (keyframes) {
    if (Status s = keyframes->close(); !s) return s;
    log::info("recorded ", keyframes->keyframes(), " keyframes into ", a.record_keyframes,
              keyframes->dropped() ? " (" + std::to_string(keyframes->dropped()) + " dropped past 1 GiB)"
                                   : std::string());
  }
  return Status::success();
}

/// trajectory_<robot>.txt, keyframes_<robot>.txt, client_<robot>.json and the summary; the exit code (1: no
/// frame or a source error, 3: keyframes the server did not accept).
int writeOutputs(const ClientArgs& a, const RobotClientConfig& config, const std::string& source_name,
                 const RobotRunResult& result) {
  const ClientRunInfo info{config.robot_id, source_name, config.transport_url, !config.link.key.empty()};
  if (Status s = writeClientOutputs(a.out, info, result); !s) return log::error(s.error()), 1;
  std::fprintf(stderr,
               "%s\nwrote %s/trajectory_%s.txt, trajectory_%s_live.txt, keyframes_%s.txt, client_%s.json\n",
               clientSummary(result).c_str(), a.out.c_str(), config.robot_id.c_str(), config.robot_id.c_str(),
               config.robot_id.c_str(), config.robot_id.c_str());
  if (result.frames == 0 && result.unreadable_frames > 0)
    return log::error(source_name, ": none of the ", result.unreadable_frames, " frames could be read"), 1;
  if (!result.source_error.empty()) return 1;
  const DeliveryReport d = deliveryReport(result, config.robot_id);
  if (d.failed()) return log::error("robot ", config.robot_id, ": ", d.message), kExitKeyframesNotAccepted;
  if (d.spooled > 0)
    log::warn("robot ", config.robot_id, ": ", d.spooled,
              " keyframes not yet acknowledged stay in the spool ", config.spool_dir, "/", config.robot_id,
              ": the next start of robot ", config.robot_id, " sends them first");
  return 0;
}

/// Pacing, final wait, stop, and with a spool: the odometry's numbering and the wait after a signal.
RobotRunOptions runOptions(const ClientArgs& a, const RobotClientConfig& config, const StopRequest* stop) {
  RobotRunOptions ro;
  ro.realtime = !a.fast;
  ro.final_wait_s = config.final_wait_s;
  ro.stop = stop;
  if (const KeyframeSpool* spool = config.link.spool.get()) {
    ro.first_keyframe_id = spool->firstKeyframeId();
    ro.first_segment = spool->firstSegment();
    ro.final_wait_when_stopped = true;
  }
  return ro;
}

int run(int argc, char** argv) {
  cli::Args args(argc, argv, {"fast", "help"});
  if (args.has("help")) {
    std::printf("%s%s%s", kUsage, sourceOptionsHelp(), datasetOptionsHelp());
    return 0;
  }
  cli::SignalThread signals;
  auto allowed = datasetOptionNames();
  allowed.insert(allowed.end(), {"dataset", "source", "record", "record-keyframes", "robot-id", "key-file",
                                 "transport", "fast", "frames", "out", "threads", "spool", "map-mode"});
  args.checkAllowed(allowed);
  std::vector<std::string> errors;
  cli::applyLogLevel(args, &errors);
  const ClientArgs a = parseArgs(args, &errors);
  errors.insert(errors.begin(), args.errors().begin(), args.errors().end());
  RobotClientConfig config;
  auto opened = loadClientConfig(args, a, &config, &errors);
  if (!errors.empty()) return cli::usageError(errors, kUsage);
  if (!opened) return log::error(opened.error()), 1;
  const OdometrySetup& setup = opened->setup;
  std::unique_ptr<FrameSource> source = std::move(opened->source);
  RecordingSource* recording = nullptr;
  if (Status s = recordInto(a.record, setup.camera, &source, &recording); !s) return log::error(s.error()), 1;

  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (ec) return log::error("cannot create ", a.out, ": ", ec.message()), 1;
  cv::setNumThreads(a.threads);
  auto transport = transport::makeTransport(config.transport_url);
  if (!transport) return log::error("transport ", config.transport_url, ": ", transport.error()), 1;
  config.link.chunk_bytes = resolveChunkBytes(config.link.chunk_bytes, config.transport_url);
  log::info("robot ", config.robot_id, " on ", config.transport_url, ", frames from ", source->describe(),
            source->live() ? " (live)" : "", ", camera from ", setup.camera_source);
  logConfiguration("configuration in effect",
                   concatConfigValues(robotClientConfigValues(config), setup.effective),
                   concatConfigValues(robotClientConfigValues({}), defaultOdometryFileValues()));

  if (Status s = openSpool(&config); !s) return log::error(s.error()), 1;
  KeyframeSpool* const spool = config.link.spool.get();
  std::unique_ptr<KeyframeStreamWriter> keyframe_recording;
  if (!a.record_keyframes.empty()) {
    keyframe_recording = std::make_unique<KeyframeStreamWriter>(a.record_keyframes, makeHello(config.link));
    config.link.keyframe_tap = [w = keyframe_recording.get()](const msg::Bytes& p) { w->append(p); };
  }
  RobotLink link(**transport, config.link);
  StopRequest stop;
  if (Status s = link.start(); !s) return log::error(s.error()), 1;
  // After the link started: a signal that came earlier waits (blocked) and then stops the run, whose outputs
  // are still written (taken during start, it made the start fail: exit 1 and no outputs).
  signals.start([&stop, &link, spool, src = source.get(), wait = config.final_wait_s](int sig) {
    log::warn(
        "signal ", sig, ": stopping (again to quit at once); outputs will still be written",
        spool ? "; waiting up to " + std::to_string(wait) + " s for acknowledgements, the rest stays spooled"
              : std::string());
    stop.request();
    src->close();  // a live source's blocking read ends at once
    if (!spool) link.stop();
  });
  RobotRunOptions ro = runOptions(a, config, &stop);
  Progress progress("robot " + config.robot_id, source->sizeHint());
  progress.setNote([&link] {
    const RobotLinkStats s = link.stats();
    return (s.diagnosis.empty() ? "" : s.diagnosis + ", ") + std::to_string(s.keyframes_acked) +
           " keyframes acknowledged" +
           (s.spool_depth > 0 ? ", " + std::to_string(s.spool_depth) + " spooled" : "");
  });
  ro.progress = [&progress](int done, int) { progress.update(static_cast<size_t>(done)); };
  const RobotRunResult result = runRobot(*source, setup.camera, setup.odometry, link, ro);
  progress.finish();
  link.stop();
  (*transport)->stop();
  if (Status s = finishRecordings(a, recording, keyframe_recording.get()); !s)
    return log::error(s.error()), 1;
  if (!result.source_error.empty()) log::error(result.source_error);
  const std::string source_name = a.source->scheme == "tum" ? a.source->path : source->describe();
  return writeOutputs(a, config, source_name, result);
}

}  // namespace
}  // namespace rgbdmap::app

int main(int argc, char** argv) {
  try {
    return rgbdmap::app::run(argc - 1, argv + 1);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rgbdmap-client: unexpected error: %s\n", e.what());
    return 1;
  }
}
