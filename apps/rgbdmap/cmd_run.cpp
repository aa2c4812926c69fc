// rgbdmap run: the main job. A mapping server and N robots in one process: each robot runs the client's
// odometry on its dataset (or its segment of one dataset), sends keyframes over the chosen transport and
// applies the server's corrections; the server closes loops, optimises one pose graph and merges the robots'
// maps. Without --dataset a synthetic sequence with exact ground truth is generated first. Writes per robot
// trajectory_<robot>.txt (every frame, map frame) and keyframes_<robot>.txt (optimised keyframes), and
// report.json (see reportJson below for the fields).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

#include <opencv2/core.hpp>

#include "commands.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/odometry_setup.hpp"
#include "rgbdmap/cli/progress.hpp"
#include "rgbdmap/common/evaluation.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/synth.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/link/robot_runner.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/server/server_config.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kUsage =
    "usage: rgbdmap run [--dataset DIR[,DIR...]] [--robots N] [--transport memq|lcm|dds|URL] [--out DIR] "
    "[options]\n"
    "  --dataset DIR[,DIR]     TUM-layout dataset(s); one per robot, or one split into --robots overlapping\n"
    "                          segments. Without it a synthetic sequence is generated first (exact ground "
    "truth)\n"
    "  --robots N              robots (default: one per dataset, else 1)\n"
    "  --overlap F             share of a segment the next robot's segment repeats (default 0.25)\n"
    "  --transport T           memq (default: in-process), lcm (UDP multicast on loopback, ttl 0), dds "
    "(Cyclone\n"
    "                          DDS with deploy/dds/cyclonedds-loopback.xml unless CYCLONEDDS_URI is set), or "
    "a URL\n"
    "  --out DIR               output folder (default: out); the map directory is DIR/map (replaced)\n"
    "  --realtime              pace every robot at its dataset's frame rate (default: as fast as possible)\n"
    "  --server-config FILE    server YAML (deploy/config/server.yaml documents every key)\n"
    "  --scene loop|sweep      synthetic scene when no dataset is given (default loop)\n"
    "  --frames N              synthetic frame count (default 300), or the first N frames of --dataset\n"
    "  --seed S                synthetic seed (default 1)\n"
    "  --threads N             OpenCV threads per robot (default 1)\n";

struct RunOptions {
  std::vector<std::string> datasets;
  std::string out = "out", scene = "loop", transport = "memq", server_config;
  long long frames = 0, seed = 1, threads = 1, robots = 0;
  double overlap = 0.25;
  bool realtime = false;
};

std::vector<std::string> splitComma(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

RunOptions parseRunOptions(cli::Args& args, std::vector<std::string>* errors) {
  RunOptions o;
  o.datasets = splitComma(args.getOr("dataset", ""));
  o.out = args.getOr("out", o.out);
  o.scene = args.getOr("scene", o.scene);
  o.transport = args.getOr("transport", o.transport);
  o.server_config = args.getOr("server-config", "");
  o.frames = args.getInt("frames").value_or(0);
  o.seed = args.getInt("seed").value_or(1);
  o.threads = args.getInt("threads").value_or(1);
  o.robots = args.getInt("robots").value_or(0);
  o.overlap = args.getDouble("overlap").value_or(o.overlap);
  o.realtime = args.has("realtime");
  if (o.scene != "loop" && o.scene != "sweep") errors->push_back("--scene must be loop or sweep");
  if (o.frames < 0 || o.frames > 100000) errors->push_back("--frames must be in [0, 100000]");
  if (o.threads < 1 || o.threads > 256) errors->push_back("--threads must be in [1, 256]");
  if (o.robots < 0 || o.robots > 64) errors->push_back("--robots must be in [1, 64]");
  if (!(o.overlap >= 0.0 && o.overlap < 1.0)) errors->push_back("--overlap must be in [0, 1)");
  if (o.datasets.size() > 1 && o.robots != 0 && o.robots != static_cast<long long>(o.datasets.size()))
    errors->push_back("with several datasets, --robots must equal their number (one robot per dataset)");
  if (!o.datasets.empty() && (args.has("scene") || args.has("seed")))
    errors->push_back("--scene and --seed only apply without --dataset");
  if (o.robots == 0) o.robots = std::max<long long>(1, static_cast<long long>(o.datasets.size()));
  return o;
}

/// memq|lcm|dds|URL -> transport URL.
std::string transportUrl(const std::string& name) {
  if (name == "memq") return "memq://";
  if (name == "lcm") return "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216";
  if (name == "dds") return "dds://?domain=0";
  return name;
}

/// Cyclone DDS must never run with its default configuration here (it multicasts on the real interface).
Status ensureDdsConfig() {
  if (std::getenv("CYCLONEDDS_URI")) return Status::success();
  const std::string xml = std::string(RGBDMAP_SOURCE_DIR) + "/deploy/dds/cyclonedds-loopback.xml";
  if (!std::filesystem::exists(xml))
    return Status::failure("CYCLONEDDS_URI is not set and " + xml + " is missing; set CYCLONEDDS_URI");
  setenv("CYCLONEDDS_URI", ("file://" + xml).c_str(), 1);
  log::info("CYCLONEDDS_URI=file://", xml, " (loopback only)");
  return Status::success();
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

msg::Bytes randomKey() {
  std::random_device rd;
  msg::Bytes key(32);
  for (auto& b : key) b = static_cast<uint8_t>(rd());
  return key;
}

struct Robot {
  std::string id;
  size_t dataset = 0;
  int first = 0, end = 0;  ///< frame range
  msg::Bytes key;
  std::unique_ptr<transport::Transport> own_transport;  ///< lcm/dds: one per party, as separate processes
  std::unique_ptr<RobotLink> link;
  RobotRunResult result;
  std::optional<AteResult> ate, ate_odometry;
};

std::string num(double v, const char* fmt = "%.6g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

std::string reportJson(const RunOptions& o, const std::vector<std::string>& datasets,
                       const std::vector<Robot>& robots, const MapServerStats& s,
                       const std::vector<std::vector<std::string>>& maps,
                       const std::optional<AteResult>& joint, double wall_s) {
  std::ostringstream j;
  j << "{\n  \"mode\": \"slam\",\n  \"transport\": " << jsonString(o.transport) << ",\n  \"datasets\": [";
  for (size_t i = 0; i < datasets.size(); ++i) j << (i ? ", " : "") << jsonString(datasets[i]);
  j << "],\n  \"wall_s\": " << num(wall_s) << ",\n  \"server\": {\n"
    << "    \"keyframes\": " << s.keyframes << ",\n"
    << "    \"loops_accepted\": " << s.loops_accepted << ",\n"
    << "    \"loops_rejected_by_graph\": " << s.loops_disabled << ",\n"
    << "    \"loop_candidates\": " << s.loop_candidates << ",\n"
    << "    \"loop_candidates_rejected\": {";
  for (int r = 1; r < kLoopRejectionCount; ++r)
    j << (r > 1 ? ", " : "") << jsonString(toString(static_cast<LoopRejection>(r))) << ": "
      << s.loops_rejected_by_reason[r];
  j << "},\n    \"optimizations\": " << s.optimizations << ",\n"
    << "    \"server_ms_per_keyframe_median\": " << num(s.ingest_ms_median) << ",\n"
    << "    \"server_ms_per_keyframe_p90\": " << num(s.ingest_ms_p90) << ",\n"
    << "    \"server_cpu_ms_per_keyframe_median\": " << num(s.ingest_cpu_ms_median) << ",\n"
    << "    \"messages_rejected\": " << s.messages_rejected << ",\n"
    << "    \"octree_leaves\": " << s.map_leaves << ",\n"
    << "    \"octree_occupied_leaves\": " << s.map_occupied_leaves << ",\n"
    << "    \"octree_memory_bytes\": " << s.map_tree_memory_bytes << ",\n"
    << "    \"octree_rebuilds\": " << s.map_rebuilds << ",\n"
    << "    \"slices_sent\": " << s.slices_sent << ",\n"
    << "    \"maps\": [";
  for (size_t m = 0; m < maps.size(); ++m) {
    j << (m ? ", " : "") << "[";
    for (size_t r = 0; r < maps[m].size(); ++r) j << (r ? ", " : "") << jsonString(maps[m][r]);
    j << "]";
  }
  j << "],\n    \"merged\": " << (maps.size() == 1 && robots.size() > 1 ? "true" : "false") << ",\n"
    << "    \"joint_ate_rmse_m\": " << (joint ? num(joint->rmse) : "null") << "\n  },\n  \"robots\": {\n";
  for (size_t i = 0; i < robots.size(); ++i) {
    const Robot& r = robots[i];
    const RobotLinkStats& l = r.result.link;
    const ServerRobotStats* sr = nullptr;
    for (const ServerRobotStats& x : s.robots)
      if (x.robot_id == r.id) sr = &x;
    const double bytes_per_kf = l.keyframes_sent ? static_cast<double>(l.bytes_sent) / l.keyframes_sent : 0.0;
    j << "    " << jsonString(r.id) << ": {\n"
      << "      \"dataset\": " << jsonString(datasets[r.dataset]) << ",\n"
      << "      \"frame_range\": [" << r.first << ", " << r.end << "],\n"
      << "      \"frames\": " << r.result.frames << ",\n"
      << "      \"keyframes\": " << r.result.keyframes << ",\n"
      << "      \"keyframes_acked\": " << l.keyframes_acked << ",\n"
      << "      \"keyframes_stored_by_server\": " << (sr ? sr->keyframes : 0) << ",\n"
      << "      \"loops\": " << (sr ? sr->loops : 0) << ",\n"
      << "      \"tracking_losses\": " << r.result.losses << ",\n"
      << "      \"ate_rmse_m\": " << (r.ate ? num(r.ate->rmse) : "null") << ",\n"
      << "      \"ate_rmse_odometry_only_m\": " << (r.ate_odometry ? num(r.ate_odometry->rmse) : "null")
      << ",\n"
      << "      \"client_ms_per_frame_median\": " << num(r.result.medianMs()) << ",\n"
      << "      \"bytes_per_keyframe_mean\": " << num(bytes_per_kf) << ",\n"
      << "      \"bytes_sent\": " << l.bytes_sent << ",\n"
      << "      \"bytes_received\": " << l.bytes_received << ",\n"
      << "      \"retransmissions\": " << l.retransmissions << ",\n"
      << "      \"corrections_received\": " << l.corrections_received << "\n"
      << "    }" << (i + 1 < robots.size() ? "," : "") << "\n";
  }
  j << "  }\n}\n";
  return j.str();
}

}  // namespace

int run(int argc, char** argv) {
  cli::Args args(argc, argv, {"help", "realtime"});
  if (args.has("help")) {
    std::printf("%s%s", kUsage, app::datasetOptionsHelp());
    return 0;
  }
  auto allowed = app::datasetOptionNames();
  allowed.insert(allowed.end(), {"dataset", "out", "scene", "frames", "seed", "threads", "robots", "overlap",
                                 "transport", "realtime", "server-config"});
  args.checkAllowed(allowed);
  std::vector<std::string> errors;
  RunOptions o = parseRunOptions(args, &errors);
  app::applyLogLevel(args, &errors);
  ServerAppConfig server_config;
  if (!o.server_config.empty()) {
    auto reader = ConfigReader::fromFile(o.server_config);
    if (!reader) {
      errors.push_back(reader.error());
    } else {
      readServerConfig(*reader, &server_config);
      for (const std::string& e : reader->errors()) errors.push_back(e);
    }
  }
  errors.insert(errors.begin(), args.errors().begin(), args.errors().end());
  if (!errors.empty()) return cli::usageError(errors, kUsage);

  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) {
    log::error("cannot create ", o.out, ": ", ec.message());
    return 1;
  }
  cv::setNumThreads(static_cast<int>(o.threads));
  const bool synthetic = o.datasets.empty();
  if (synthetic) {
    const std::string dir = synthesize(o);
    if (dir.empty()) return 1;
    o.datasets.push_back(dir);
  }
  // Datasets and their cameras.
  std::vector<TumDataset> datasets;
  std::vector<app::OdometrySetup> setups;
  for (const std::string& dir : o.datasets) {
    setups.push_back(app::loadOdometrySetup(args, dir, &errors));
    if (!errors.empty()) return cli::usageError(errors, kUsage);
    auto d = TumDataset::open(dir, setups.back().dataset);
    if (!d) {
      log::error(d.error());
      return 1;
    }
    datasets.push_back(std::move(*d));
  }
  logConfiguration("configuration in effect (camera of the first dataset)",
                   concatConfigValues(setups.front().effective, serverConfigValues(server_config)));
  // Robots: one per dataset, or overlapping segments of the one dataset.
  std::vector<Robot> robots(static_cast<size_t>(o.robots));
  for (size_t i = 0; i < robots.size(); ++i) {
    Robot& r = robots[i];
    r.id = "robot" + std::to_string(i);
    r.key = randomKey();
    r.dataset = datasets.size() > 1 ? i : 0;
    const int total = static_cast<int>(datasets[r.dataset].size());
    const int frames =
        (!synthetic && o.frames > 0) ? std::min<int>(total, static_cast<int>(o.frames)) : total;
    if (datasets.size() > 1 || robots.size() == 1) {
      r.first = 0;
      r.end = frames;
    } else {
      const double seg = static_cast<double>(frames) / robots.size();
      const int half_overlap = static_cast<int>(std::lround(0.5 * o.overlap * seg));
      r.first = std::max(0, static_cast<int>(std::lround(i * seg)) - half_overlap);
      r.end = std::min(frames, static_cast<int>(std::lround((i + 1) * seg)) + half_overlap);
    }
  }
  // Transport(s): memq is one in-process bus; lcm and dds give every party its own instance (as processes).
  const std::string url = transportUrl(o.transport);
  if (url.rfind("dds://", 0) == 0)
    if (const Status s = ensureDdsConfig(); !s) {
      log::error(s.error());
      return 1;
    }
  auto server_transport = transport::makeTransport(url);
  if (!server_transport) {
    log::error("transport ", url, ": ", server_transport.error());
    return 1;
  }
  const bool shared_bus = url.rfind("memq://", 0) == 0;
  // The server: a fresh map directory, every robot with its own key (signed messages, as in a deployment).
  MapServerConfig config = server_config.server;
  config.map_dir = o.out + "/map";
  if (std::filesystem::exists(config.map_dir)) {
    if (!std::filesystem::exists(config.map_dir + "/MANIFEST")) {
      log::error(config.map_dir, " exists and is not an rgbdmap map directory; refusing to replace it");
      return 1;
    }
    std::filesystem::remove_all(config.map_dir, ec);
  }
  config.robots.clear();
  msg::KeyStore keys;
  for (const Robot& r : robots) {
    config.robots.push_back(r.id);
    (void)keys.add(r.id, r.key);
  }
  MapServer server(config, **server_transport, std::move(keys));
  if (const Status s = server.start(); !s) {
    log::error(s.error());
    return 1;
  }
  for (Robot& r : robots) {
    transport::Transport* t = server_transport->get();
    if (!shared_bus) {
      auto own = transport::makeTransport(url);
      if (!own) {
        log::error("transport ", url, ": ", own.error());
        return 1;
      }
      r.own_transport = std::move(*own);
      t = r.own_transport.get();
    }
    RobotLinkOptions lo;
    lo.robot_id = r.id;
    lo.key = r.key;
    lo.camera = setups[r.dataset].camera;
    r.link = std::make_unique<RobotLink>(*t, lo);
  }
  if (const Status s = (*server_transport)->start(); !s) {
    log::error("transport start: ", s.error());
    return 1;
  }
  for (Robot& r : robots) {
    if (r.own_transport)
      if (const Status s = r.own_transport->start(); !s) {
        log::error("transport start: ", s.error());
        return 1;
      }
    if (const Status s = r.link->start(); !s) {
      log::error(r.id, ": ", s.error());
      return 1;
    }
  }
  log::info("running ", robots.size(), " robot(s) over ", url, ", server map directory ", config.map_dir);

  // Robots run concurrently, each on its own thread, as they would on their own computers.
  const auto t0 = std::chrono::steady_clock::now();
  size_t total_frames = 0;
  for (const Robot& r : robots) total_frames += static_cast<size_t>(r.end - r.first);
  // One progress line for all robots (frames done, rate, ETA) on a terminal; silent in CI and logs.
  app::Progress progress("rgbdmap run", total_frames);
  std::mutex progress_mutex;
  size_t frames_done = 0;
  auto advance = [&] {
    std::lock_guard<std::mutex> lock(progress_mutex);
    progress.update(++frames_done);
  };
  std::vector<std::thread> threads;
  for (Robot& r : robots) {
    threads.emplace_back([&r, &datasets, &setups, &o, &advance] {
      RobotRunOptions ro;
      ro.progress = [&advance](int, int) { advance(); };
      ro.first_frame = r.first;
      ro.end_frame = r.end;
      ro.realtime = o.realtime;
      ro.final_wait_s = 60.0;
      r.result =
          runRobot(datasets[r.dataset], setups[r.dataset].camera, setups[r.dataset].odometry, *r.link, ro);
    });
  }
  for (std::thread& t : threads) t.join();
  progress.finish();
  // Let the last optimisation reach every robot, then re-anchor each robot's frames on it.
  server.waitIdle(60.0);
  const auto server_keyframes = server.keyframes();
  for (Robot& r : robots) {
    int last = -1;
    for (const ServerKeyframe& k : server_keyframes)
      if (k.robot_id == r.id) last = k.keyframe_id;
    if (last >= 0) r.link->waitForCorrection(last, 10.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // a newer correction may be in flight
    reanchorFinalMap(*r.link, &r.result);
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  // Outputs.
  Trajectory joint_est, joint_gt;
  for (Robot& r : robots) {
    Trajectory keyframes;
    for (const ServerKeyframe& k : server_keyframes)
      if (k.robot_id == r.id) keyframes.push_back({k.timestamp, k.T_map_kf});
    const std::string traj = o.out + "/trajectory_" + r.id + ".txt";
    const std::string kfs = o.out + "/keyframes_" + r.id + ".txt";
    for (const auto& [path, t, what] : {std::tuple{traj, &r.result.final_map, "every frame"},
                                        std::tuple{kfs, &keyframes, "optimised keyframes"}}) {
      if (const Status s =
              writeTumTrajectory(path, *t, std::string("rgbdmap run, ") + r.id + ", " + what + ", map frame");
          !s) {
        log::error(s.error());
        return 1;
      }
    }
    const auto& gt = datasets[r.dataset].groundTruth();
    if (gt) {
      if (auto a = computeAte(*gt, r.result.final_map)) r.ate = *a;
      if (auto a = computeAte(*gt, r.result.odometry)) r.ate_odometry = *a;
      if (datasets.size() == 1)
        for (const StampedPose& p : r.result.final_map) joint_est.push_back(p);
    }
  }
  // One alignment for all robots (same dataset): only a correct merge puts them in one frame.
  std::optional<AteResult> joint;
  if (!joint_est.empty() && robots.size() > 1) {
    std::sort(joint_est.begin(), joint_est.end(),
              [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });
    Trajectory distinct;
    for (const StampedPose& p : joint_est)
      if (distinct.empty() || p.timestamp > distinct.back().timestamp + 1e-9) distinct.push_back(p);
    if (auto a = computeAte(*datasets[0].groundTruth(), distinct)) joint = *a;
  }
  const MapServerStats stats = server.stats();
  const auto maps = server.mergedMaps();
  // The occupancy map and what a person looks at first: map.bt/.ot, map.ply, slice_<robot>.pgm/.yaml,
  // map.png.
  if (config.occupancy_enabled)
    if (const Status s = server.writeMapOutputs(o.out); !s) log::warn("map files: ", s.error());
  for (Robot& r : robots) {
    r.link->stop();
    if (r.own_transport) r.own_transport->stop();
  }
  (*server_transport)->stop();
  server.stop();
  std::ofstream(o.out + "/report.json") << reportJson(o, o.datasets, robots, stats, maps, joint, wall_s);

  std::fprintf(stderr, "rgbdmap run: %zu robot(s) over %s, %.1f s\n", robots.size(), url.c_str(), wall_s);
  for (const Robot& r : robots)
    std::fprintf(
        stderr,
        "  %s frames %d-%d: %d keyframes (%llu acked), ATE %s m (odometry alone %s m), %.1f ms/frame\n",
        r.id.c_str(), r.first, r.end, r.result.keyframes,
        static_cast<unsigned long long>(r.result.link.keyframes_acked),
        r.ate ? num(r.ate->rmse, "%.4f").c_str() : "n/a",
        r.ate_odometry ? num(r.ate_odometry->rmse, "%.4f").c_str() : "n/a", r.result.medianMs());
  std::fprintf(
      stderr, "  server: %d keyframes, %d loops (%d rejected by the graph), %zu map(s)%s, %.1f ms/keyframe\n",
      stats.keyframes, stats.loops_accepted, stats.loops_disabled, maps.size(),
      joint ? (", joint ATE " + num(joint->rmse, "%.4f") + " m").c_str() : "", stats.ingest_ms_median);
  std::fprintf(
      stderr,
      "  map: %zu octree leaves (%zu occupied), %.1f MB in memory, %llu rebuild(s), %llu slices sent\n",
      static_cast<size_t>(stats.map_leaves), static_cast<size_t>(stats.map_occupied_leaves),
      stats.map_tree_memory_bytes / 1e6, static_cast<unsigned long long>(stats.map_rebuilds),
      static_cast<unsigned long long>(stats.slices_sent));
  std::fprintf(
      stderr,
      "wrote %s/: trajectory_<robot>.txt, keyframes_<robot>.txt, report.json, map.png, map.bt, map.ot, "
      "map.ply, slice_<robot>.pgm/.yaml, map/\n",
      o.out.c_str());
  return 0;
}

}  // namespace rgbdmap::cmd
