// rgbdmap run: the main job. A mapping server and N robots in one process: each robot runs the client's
// odometry on its dataset (or its segment of one dataset), sends keyframes over the chosen transport and
// applies the server's corrections; the server closes loops, optimises one pose graph and merges the robots'
// maps. Without --dataset a synthetic sequence with exact ground truth is generated first. Writes per robot
// trajectory_<robot>.txt (every frame, map frame) and keyframes_<robot>.txt (optimised keyframes), the map
// files, and report.json (run_report.hpp).
// Steps: parse (run_plan) -> plan the robots (run_plan) -> start a LocalDeployment (local_deployment) ->
// run the robots -> write the outputs (run_report).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <optional>
#include <thread>

#include <opencv2/core.hpp>

#include "commands.hpp"
#include "local_deployment.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/odometry_setup.hpp"
#include "rgbdmap/cli/progress.hpp"
#include "rgbdmap/cli/source_setup.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/server/server_config.hpp"
#include "rgbdmap/source/seven_scenes.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "run_plan.hpp"
#include "run_report.hpp"
#include "run_viewer.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kRunUsage =
    "usage: rgbdmap run [--dataset DIR[,DIR...]] [--robots N] [--transport memq|lcm|dds|URL] [--out DIR] "
    "[options]\n"
    "  --dataset DIR[,DIR]     TUM-layout dataset(s); one per robot, or one split into --robots overlapping\n"
    "                          segments. Without it a synthetic sequence is generated first (exact ground "
    "truth).\n"
    "                          A 7-Scenes sequence folder is read as --source 7scenes:DIR\n"
    "  --source URL[,URL]      instead of --dataset: frame sources (bag:FILE.bag, openni2:, tum:DIR; see\n"
    "                          rgbdmap odometry --help), each converted into DIR/source_<i>/ first and run\n"
    "                          as a dataset (a live camera needs --frames N)\n"
    "  --robots N              robots (default: one per dataset, else 1)\n"
    "  --overlap F             share of a segment the next robot's segment repeats (default 0.25)\n"
    "  --transport T           memq (default: in-process), lcm (UDP multicast on loopback, ttl 0), dds "
    "(Cyclone\n"
    "                          DDS with deploy/dds/cyclonedds-loopback.xml unless CYCLONEDDS_URI is set), or "
    "a URL\n"
    "  --out DIR               output folder (default: out); the map directory is DIR/map (replaced)\n"
    "  --realtime              pace every robot at its dataset's frame rate (default: as fast as possible)\n"
    "  --async                 as fast as possible without waiting for the server's correction after each\n"
    "                          keyframe: faster, but the map then depends on the machine's load (default:\n"
    "                          wait, the same map on a busy machine; --realtime never waits)\n"
    "  --server-config FILE    server YAML (deploy/config/server.yaml documents every key)\n"
    "  --scene loop|sweep      synthetic scene when no dataset is given (default loop)\n"
    "  --frames N              synthetic frame count (default 300), or the first N frames of --dataset\n"
    "  --frames A:B            frames A to B-1 of --dataset\n"
    "  --map DIR               serve this stored map directory instead of a new DIR/map: the run extends it\n"
    "                          (robots that see mapped places join it through loop closure)\n"
    "  --frozen-map            with --map: every robot localises in the stored map without changing it\n"
    "                          (keyframes acknowledged, never stored; the map directory stays as it was)\n"
    "  --seed S                synthetic seed (default 1)\n"
    "  --threads N             OpenCV threads per robot (default 1)\n"
    "  --viewer [PORT]         live map viewer at http://127.0.0.1:PORT/ and for Foxglove (default 8765),\n"
    "                          kept open after the run until Ctrl-C\n"
    "  --record FILE.mcap      with --viewer: also record the viewer's topics (Foxglove schemas, JSON) into\n"
    "                          an MCAP file that Foxglove opens; written when the viewer closes (Ctrl-C)\n"
    "  --ros2                  publish the map as ROS 2 topics over Cyclone DDS (as rgbdmap-ros2:\n"
    "                          /map, /tf, /octomap_binary, /map_cloud, /<robot>/pose|path|local_map) in\n"
    "                          ROS_DOMAIN_ID, kept after the run until Ctrl-C\n";

/// The datasets the robots read and, per dataset, its camera, odometry and reader settings.
struct RunInputs {
  std::vector<TumDataset> datasets;
  std::vector<app::OdometrySetup> setups;
  bool synthetic = false;
};

/// Parses the command line and the server configuration; every problem is appended to *errors.
RunOptions parseRun(cli::Args& args, ServerAppConfig* server_config, std::vector<std::string>* errors) {
  auto allowed = app::datasetOptionNames();
  allowed.insert(allowed.end(), {"dataset", "source", "out", "scene", "frames", "seed", "threads", "robots",
                                 "overlap", "transport", "realtime", "async", "server-config", "viewer",
                                 "record", "ros2", "map", "frozen-map"});
  args.checkAllowed(allowed);
  RunOptions o = parseRunOptions(args, errors);
  if (args.has("source") && args.has("dataset"))
    errors->push_back("--dataset DIR and --source URL are one choice (--dataset DIR = --source tum:DIR)");
  cli::applyLogLevel(args, errors);
  if (!o.server_config.empty()) {
    auto reader = ConfigReader::fromFile(o.server_config);
    if (!reader) {
      errors->push_back(reader.error());
    } else {
      readServerConfig(*reader, server_config);
      for (const std::string& e : reader->errors()) errors->push_back(e);
    }
  }
  errors->insert(errors->begin(), args.errors().begin(), args.errors().end());
  return o;
}

std::string synthesize(const RunOptions& o) {
  SynthConfig cfg;
  cfg.scene = o.scene;
  cfg.frames = o.frames > 0 ? static_cast<int>(o.frames) : cfg.frames;
  cfg.seed = static_cast<uint64_t>(o.seed);
  const std::string dir = o.out + "/synthetic_" + o.scene;
  log::info("no --dataset: synthesising ", cfg.frames, " frames of the '", o.scene, "' scene into ", dir);
  const Status s = writeSyntheticSequence(cfg, dir);
  if (!s) {
    log::error("synthesis failed: ", s.error());
    return "";
  }
  return dir;
}

/// --source URL[,URL]: each source written into <out>/source_<i> (a recording once, so that robots can
/// split it and the report can evaluate it), then run as --dataset; so is a --dataset folder in the 7-Scenes
/// layout. The exit code on failure.
std::optional<int> convertSources(cli::Args& args, RunOptions* o) {
  for (size_t i = 0; i < o->datasets.size(); ++i) {  // --dataset DIR of 7-Scenes reads as 7scenes:DIR
    if (!isSevenScenesFolder(o->datasets[i])) continue;
    const std::string dir = o->out + "/source_" + std::to_string(i);
    auto url = SourceUrl::parse("7scenes:" + o->datasets[i]);
    if (!url) return cli::usageError({"--dataset: " + url.error()}, kRunUsage);
    if (int rc = convertSource(args, *url, dir, o->frames, kRunUsage); rc != 0) return rc;
    o->datasets[i] = dir;
  }
  if (!args.has("source")) return std::nullopt;
  std::vector<std::string> urls;
  std::string list = args.getOr("source", "");
  for (size_t start = 0; start <= list.size();) {
    const size_t comma = std::min(list.find(',', start), list.size());
    if (comma > start) urls.push_back(list.substr(start, comma - start));
    start = comma + 1;
  }
  if (urls.empty()) return cli::usageError({"--source needs a URL"}, kRunUsage);
  for (size_t i = 0; i < urls.size(); ++i) {
    auto url = SourceUrl::parse(urls[i]);
    if (!url) return cli::usageError({"--source: " + url.error()}, kRunUsage);
    if (url->scheme == "tum" && url->query.empty()) {  // a folder already is a dataset
      o->datasets.push_back(url->path);
      continue;
    }
    const std::string dir = o->out + "/source_" + std::to_string(i);
    if (int rc = convertSource(args, *url, dir, o->frames, kRunUsage); rc != 0) return rc;
    o->datasets.push_back(dir);
  }
  if (o->robots == 0 || (o->datasets.size() > 1 && !args.has("robots")))
    o->robots = static_cast<long long>(o->datasets.size());
  return std::nullopt;
}

/// Creates --out, synthesises a sequence when no dataset was given (added to o->datasets) and opens the
/// datasets. Returns the exit code on failure (2: a dataset's options are wrong).
std::optional<int> loadInputs(cli::Args& args, RunOptions* o, RunInputs* in) {
  std::error_code ec;
  std::filesystem::create_directories(o->out, ec);
  if (ec) return log::error("cannot create ", o->out, ": ", ec.message()), 1;
  if (std::optional<int> rc = convertSources(args, o)) return rc;
  in->synthetic = o->datasets.empty();
  if (in->synthetic) {
    const std::string dir = synthesize(*o);
    if (dir.empty()) return 1;
    o->datasets.push_back(dir);
  }
  for (const std::string& dir : o->datasets) {
    std::vector<std::string> errors;
    in->setups.push_back(app::loadOdometrySetup(args, dir, &errors));
    if (!errors.empty()) return cli::usageError(errors, kRunUsage);
    auto d = TumDataset::open(dir, in->setups.back().dataset);
    if (!d) return log::error(d.error()), 1;
    in->datasets.push_back(std::move(*d));
  }
  return std::nullopt;
}

/// <out>/map is replaced by a fresh map directory, unless it is something else.
Status clearMapDir(const std::string& map_dir) {
  if (!std::filesystem::exists(map_dir)) return Status::success();
  if (!std::filesystem::exists(map_dir + "/MANIFEST"))
    return Status::failure(map_dir + " exists and is not an rgbdmap map directory; refusing to replace it");
  std::error_code ec;
  std::filesystem::remove_all(map_dir, ec);
  return Status::success();
}

Result<std::unique_ptr<LocalDeployment>> deploy(const RunOptions& o, const ServerAppConfig& server_config,
                                                const RunInputs& in, const std::vector<RobotPlan>& plans) {
  MapServerConfig config = server_config.server;
  config.map_dir = o.map.empty() ? o.out + "/map" : o.map;
  if (o.frozen_map) config.frozen_map = true;
  if (!o.map.empty() && !std::filesystem::exists(o.map + "/MANIFEST"))
    return Result<std::unique_ptr<LocalDeployment>>::failure("--map " + o.map +
                                                             " is not an rgbdmap map directory");
  if (const Status s = o.map.empty() ? clearMapDir(config.map_dir) : Status::success(); !s)
    return Result<std::unique_ptr<LocalDeployment>>::failure(s.error());
  std::vector<LocalRobotSpec> robots;
  for (const RobotPlan& p : plans) robots.push_back({p.id, p.key, in.setups[p.dataset].camera});
  return LocalDeployment::start(transportUrl(o.transport), std::move(config), robots);
}

/// Robots run concurrently, each on its own thread, as they would on their own computers; one progress
/// line for all of them (frames done, rate, ETA) on a terminal, silent in CI and logs.
std::vector<RobotOutcome> runRobots(const RunOptions& o, const RunInputs& in,
                                    const std::vector<RobotPlan>& plans, LocalDeployment& deployment) {
  size_t total_frames = 0;
  for (const RobotPlan& p : plans) total_frames += static_cast<size_t>(p.end - p.first);
  app::Progress progress("rgbdmap run", total_frames);
  std::mutex progress_mutex;
  size_t frames_done = 0;
  RobotRunOptions ro;
  ro.progress = [&](int, int) {
    std::lock_guard<std::mutex> lock(progress_mutex);
    progress.update(++frames_done);
  };
  ro.realtime = o.realtime;
  ro.final_wait_s = 60.0;
  // A recording run as fast as possible waits for the server after each keyframe: the same map whatever
  // the machine's load (RobotRunOptions::lockstep_s). Paced or --async robots do not wait.
  ro.lockstep_s = o.realtime || o.async ? 0.0 : 10.0;
  std::vector<RobotOutcome> robots(plans.size());
  std::vector<std::thread> threads;
  for (size_t i = 0; i < plans.size(); ++i) {
    threads.emplace_back([&, i, ro]() mutable {
      const RobotPlan& p = plans[i];
      ro.first_frame = p.first;
      ro.end_frame = p.end;
      const app::OdometrySetup& setup = in.setups[p.dataset];
      robots[i].result =
          runRobot(in.datasets[p.dataset], setup.camera, setup.odometry, deployment.link(i), ro);
    });
  }
  for (std::thread& t : threads) t.join();
  progress.finish();
  return robots;
}

/// Runs the robots, lets the server's last optimisation reach every robot and re-anchors each robot's
/// frames on it; then collects what the server holds and writes the map files.
ServerOutcome runDeployment(const RunOptions& o, const RunInputs& in, const std::vector<RobotPlan>& plans,
                            LocalDeployment& deployment, std::vector<RobotOutcome>* robots) {
  const auto t0 = std::chrono::steady_clock::now();
  *robots = runRobots(o, in, plans, deployment);
  deployment.settle(60.0, 10.0);
  for (size_t i = 0; i < plans.size(); ++i) reanchorFinalMap(deployment.link(i), &(*robots)[i].result);
  ServerOutcome server;
  server.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  server.keyframes = deployment.server().keyframes();
  return server;
}

/// The trajectories, the accuracy, what the server reports and the map files (then the deployment stops).
int writeOutputs(const RunOptions& o, const RunInputs& in, const std::vector<RobotPlan>& plans,
                 bool map_files, LocalDeployment& deployment, std::vector<RobotOutcome>* robots,
                 ServerOutcome* server) {
  if (const Status s = writeTrajectories(o.out, plans, *robots, server->keyframes); !s)
    return log::error(s.error()), 1;
  evaluateRun(in.datasets, plans, robots, server);
  server->stats = deployment.server().stats();
  server->maps = deployment.server().mergedMaps();
  // The occupancy map and what a person looks at first: map.bt/.ot, map.ply, slice_<robot>.pgm/.yaml,
  // map_<id>.pgm/.yaml,
  // map.png.
  if (map_files)
    if (const Status s = deployment.server().writeMapOutputs(o.out); !s) log::warn("map files: ", s.error());
  deployment.stop();
  if (const Status s = writeJsonFile(o.out + "/report.json", reportJson(o, plans, *robots, *server)); !s)
    return log::error(s.error()), 1;
  printRunSummary(o, transportUrl(o.transport), plans, *robots, *server);
  int status = 0;  // a robot skips unreadable frames; one that could read none of its frames fails the run
  for (size_t i = 0; i < plans.size(); ++i) {
    const RobotRunResult& r = (*robots)[i].result;
    if (r.frames == 0 && r.unreadable_frames > 0) {
      log::error(plans[i].id, ": none of its ", r.unreadable_frames, " frames could be read");
      status = 1;
    }
  }
  return status;
}

}  // namespace

int run(int argc, char** argv) {
  const auto started = std::chrono::steady_clock::now();
  ViewerArgv viewer_argv(argc, argv);
  cli::Args args(viewer_argv.argc(), viewer_argv.argv(), {"help", "realtime", "async", "ros2", "frozen-map"});
  if (args.has("help")) {
    std::printf("%s%s", kRunUsage, app::datasetOptionsHelp());
    return 0;
  }
  std::vector<std::string> errors;
  ServerAppConfig server_config;
  RunOptions o = parseRun(args, &server_config, &errors);
  const int viewer_port = viewerPort(args, &errors);
  const std::string record_path = args.getOr("record", "");
  if (!record_path.empty() && viewer_port < 0) errors.push_back("--record FILE.mcap needs --viewer");
  if (!errors.empty()) return cli::usageError(errors, kRunUsage);
  cv::setNumThreads(static_cast<int>(o.threads));
  RunInputs in;
  if (const auto failed = loadInputs(args, &o, &in)) return *failed;
  logConfiguration("configuration in effect (camera of the first dataset)",
                   concatConfigValues(in.setups.front().effective, serverConfigValues(server_config)),
                   concatConfigValues(defaultOdometryFileValues(), serverConfigValues({})));
  std::vector<size_t> dataset_frames;
  for (const TumDataset& d : in.datasets) dataset_frames.push_back(d.size());
  const std::vector<RobotPlan> plans = planRobots(o, dataset_frames, in.synthetic);
  auto deployment = deploy(o, server_config, in, plans);
  if (!deployment) return log::error(deployment.error()), 1;
  std::unique_ptr<RunViewer> viewer;
  if (viewer_port >= 0 || args.has("ros2")) {
    const RunViewerOptions outputs{viewer_port, record_path, args.has("ros2")};
    auto started = startRunViewer(outputs, transportUrl(o.transport), plans, **deployment);
    if (!started) return log::error(started.error()), 1;
    viewer = std::move(*started);
  }
  log::info("running ", plans.size(), " robot(s) over ", transportUrl(o.transport), ", server map directory ",
            o.map.empty() ? o.out + "/map" : o.map,
            o.frozen_map ? " (frozen: the robots localise in it)" : "");
  std::vector<RobotOutcome> robots;
  const double prepare_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  ServerOutcome server = runDeployment(o, in, plans, **deployment, &robots);
  server.prepare_s = prepare_s;
  server.prepare_what = in.synthetic         ? "synthesising the sequence"
                        : args.has("source") ? "converting the sources"
                                             : "reading the datasets";
  const int status =
      writeOutputs(o, in, plans, server_config.server.occupancy_enabled, **deployment, &robots, &server);
  if (viewer) keepViewerOpen(*viewer);
  return status;
}

}  // namespace rgbdmap::cmd
