// rgbdmap-server: the mapping service as a process. Serves robots over the configured transport until
// SIGINT/SIGTERM; the map directory holds everything acknowledged, so a restart resumes the same map.
#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/server/server_config.hpp"
#include "rgbdmap/server/stats_json.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace {

const char* kUsage =
    "usage: rgbdmap-server --config FILE [options]\n"
    "  --config FILE       YAML configuration (deploy/config/server.yaml documents every key)\n"
    "  --map-dir DIR       map directory (overrides server.map_dir)\n"
    "  --transport URL     memq:// | udpm://239.255.76.67:7667?ttl=0 | dds://?domain=0 (overrides)\n"
    "                      dds:// needs CYCLONEDDS_URI, e.g. file://$PWD/deploy/dds/cyclonedds-loopback.xml\n"
    "  --robots a,b,c      robots to serve (overrides server.robots)\n"
    "  --keys-file FILE    the robots' keys (overrides server.keys_file; `rgbdmap keys new R...` writes it)\n"
    "  --open              accept unsigned messages (local demos only)\n"
    "  --frozen-map        every robot localises in the stored map without changing it (server.frozen_map):\n"
    "                      keyframes are acknowledged, never stored; only server_summary.json is written\n"
    "  --status-every S    print a status line every S seconds (default 5; 0: never)\n"
    "  --log-level L       debug|info|warn|error\n"
    "On SIGINT/SIGTERM it stops and writes keyframes_<robot>.txt (optimised, map frame) into the map "
    "directory,\n"
    "server_summary.json (the server's figures: deploy/schemas/server_stats.schema.json) and (map.enabled)\n"
    "the map files: map.bt, map.ot, map.ply, map.png, slice_<robot>.pgm/.yaml, map_<id>.pgm/.yaml (the 2-D\n"
    "map of each map, ROS map_server / nav2), each written to a temporary\n"
    "name, synced and renamed. Exit status: 0 stopped and every file written; 1 start-up failure, or a file\n"
    "could not be written (the previous one stays); 2 usage or configuration error.\n";

/// server_summary.json in the map directory: what the deployment scripts and tests check after a run.
rgbdmap::Json summaryJson(const rgbdmap::MapServer& server) {
  return rgbdmap::serverStatsJson(server.stats(), server.mergedMaps());
}

/// SIGINT and SIGTERM, blocked in every thread (call before any thread starts: threads inherit the mask)
/// and taken synchronously by waitForStopSignal.
sigset_t blockStopSignals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  return set;
}

void printStatus(const rgbdmap::MapServer& server) {
  const rgbdmap::MapServerStats s = server.stats();
  // Robots that localise, and those of them not placed yet (a robot in a place the map does not hold).
  std::string localising;
  int count = 0;
  for (const rgbdmap::ServerRobotStats& r : s.robots) {
    if (r.mode != "localize") continue;
    ++count;
    if (!r.placed) localising += (localising.empty() ? " unplaced: " : ",") + r.robot_id;
  }
  if (count > 0) localising = " localising " + std::to_string(count) + localising;
  std::fprintf(stderr,
               "[server] robots %zu keyframes %d (+%d stored, not placed yet) loops %d (disabled %d) maps %d "
               "ingest %.1f ms rejected %llu%s%s\n",
               s.robots.size(), s.keyframes, s.keyframes_deferred, s.loops_accepted, s.loops_disabled, s.maps,
               s.ingest_ms_median, static_cast<unsigned long long>(s.inbox.messages_rejected),
               localising.c_str(), s.store_failed ? (" STORE FAILED: " + s.store_error).c_str() : "");
}

/// Sleeps until SIGINT or SIGTERM arrives, printing a status line every `status_every` seconds (0: never).
void waitForStopSignal(const sigset_t& signals, double status_every, const rgbdmap::MapServer& server) {
  using Clock = std::chrono::steady_clock;
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(status_every));
  auto next_status = Clock::now() + period;
  for (;;) {
    int sig = -1;
    if (status_every <= 0) {
      if (sigwait(&signals, &sig) == 0) break;
      continue;
    }
    const double left_s = std::max(0.0, std::chrono::duration<double>(next_status - Clock::now()).count());
    timespec timeout{static_cast<time_t>(left_s), static_cast<long>((left_s - std::floor(left_s)) * 1e9)};
    if (sigtimedwait(&signals, nullptr, &timeout) >= 0) break;
    if (errno != EAGAIN) continue;  // EINTR: another signal
    printStatus(server);
    next_status += period;
  }
}

/// keyframes_<robot>.txt, server_summary.json and (map.enabled) the map files into the map directory, each
/// written atomically. Returns how many writes failed (each logged); `map_files`: the map files were written.
int writeFinalOutputs(const rgbdmap::MapServer& server, const rgbdmap::ServerAppConfig& config,
                      bool* map_files) {
  using namespace rgbdmap;
  int failed = 0;
  *map_files = false;
  if (config.server.frozen_map) {
    // Nothing the robots sent changed the map: its files stay as they are; the run's figures go next to it.
    if (const Status w = writeJsonFile(config.server.map_dir + "/server_summary.json", summaryJson(server));
        !w) {
      log::error(w.error());
      ++failed;
    }
    return failed;
  }
  std::map<std::string, Trajectory> by_robot;
  for (const ServerKeyframe& k : server.keyframes())
    by_robot[k.robot_id].push_back({k.timestamp, k.T_map_kf});
  for (const auto& [robot, traj] : by_robot) {
    const std::string path = config.server.map_dir + "/keyframes_" + robot + ".txt";
    if (const Status s = writeTumTrajectory(path, traj, "rgbdmap-server, optimised keyframes, map frame");
        !s) {
      log::error(s.error());
      ++failed;
    }
  }
  if (const Status w = writeJsonFile(config.server.map_dir + "/server_summary.json", summaryJson(server));
      !w) {
    log::error(w.error());
    ++failed;
  }
  *map_files = false;
  if (config.server.occupancy_enabled && !server.keyframes().empty()) {
    const Status st = server.writeMapOutputs(config.server.map_dir);
    if (!st) log::error("map files: ", st.error());
    failed += st ? 0 : 1;
    *map_files = st.ok();
  }
  return failed;
}

using namespace rgbdmap;

struct ServerOptions {
  ServerAppConfig config;
  double status_every = 5.0;
};

/// The command line and the configuration file; every problem goes to *errors.
ServerOptions parseOptions(cli::Args& args, std::vector<std::string>* errors) {
  ServerOptions o;
  if (const auto path = args.get("config")) {
    auto reader = ConfigReader::fromFile(*path);
    if (!reader) {
      errors->push_back(reader.error());
    } else {
      readServerConfig(*reader, &o.config);
      for (const std::string& e : reader->errors()) errors->push_back(e);
    }
  } else {
    errors->push_back("--config FILE is required");
  }
  if (const auto v = args.get("map-dir")) o.config.server.map_dir = *v;
  if (const auto v = args.get("transport")) o.config.transport_url = *v;
  if (const Status s = transport::checkTransportUrl(o.config.transport_url); !s) errors->push_back(s.error());
  if (const auto v = args.get("robots")) o.config.server.robots = splitList(*v);
  if (const auto v = args.get("keys-file")) o.config.keys_file = *v;
  if (args.has("open")) o.config.open_mode = true;
  if (args.has("frozen-map")) o.config.server.frozen_map = true;
  o.status_every = args.getDouble("status-every").value_or(5.0);
  cli::applyLogLevel(args, errors);
  if (const std::string p = o.config.server.validate(); !p.empty()) errors->push_back(p);
  return o;
}

/// The robots' keys (server.keys_file), or open mode; the reason when neither.
Result<msg::KeyStore> loadKeys(const ServerAppConfig& config) {
  msg::KeyStore keys = config.open_mode ? msg::KeyStore::openMode() : msg::KeyStore();
  if (!config.keys_file.empty()) return msg::readKeysFile(config.keys_file, std::move(keys));
  if (!config.open_mode)
    return Result<msg::KeyStore>::failure(
        "no server.keys_file and open mode is off: no robot could be authenticated");
  return keys;
}

void printFinalSummary(const MapServer& server, const ServerAppConfig& config, bool map_files) {
  const MapServerStats s = server.stats();
  std::fprintf(
      stderr,
      "[server] final: keyframes %d loops %d maps %d; octree %zu leaves (%zu occupied), %.1f MB, "
      "%llu rebuilds, %llu slices sent; wrote keyframes_<robot>.txt%s to %s\n",
      s.keyframes, s.loops_accepted, s.maps, s.map_leaves, s.map_occupied_leaves,
      s.map_tree_memory_bytes / 1e6, static_cast<unsigned long long>(s.map_rebuilds),
      static_cast<unsigned long long>(s.slices_sent),
      map_files ? ", map.bt, map.ot, map.ply, map.png, slice_<robot>.pgm/.yaml, map_<id>.pgm/.yaml" : "",
      config.server.map_dir.c_str());
}

/// Serves until SIGINT or SIGTERM, then waits for queued work and writes the outputs; the exit code.
int serve(const ServerOptions& options, msg::KeyStore keys, const sigset_t& stop_signals) {
  const ServerAppConfig& config = options.config;
  auto transport = transport::makeTransport(config.transport_url);
  if (!transport) {
    log::error("transport ", config.transport_url, ": ", transport.error());
    return 1;
  }
  MapServer server(config.server, **transport, std::move(keys));
  if (const Status s = server.start(); !s) {
    log::error(s.error());
    return 1;
  }
  if (const Status s = (*transport)->start(); !s) {
    log::error("transport start: ", s.error());
    return 1;
  }
  log::info("ready on ", config.transport_url, " (SIGINT or SIGTERM stops and writes the outputs)");
  waitForStopSignal(stop_signals, options.status_every, server);
  log::info("stopping: waiting up to ", config.server.stop_wait_s, " s for queued work");
  if (!server.waitIdle(config.server.stop_wait_s))
    log::warn("stopping: work still queued after ", config.server.stop_wait_s,
              " s (server.stop_wait_s); the outputs show the map as processed so far");
  (*transport)->stop();
  server.stop();
  bool map_files = false;
  const int failed_writes = writeFinalOutputs(server, config, &map_files);
  printFinalSummary(server, config, map_files);
  if (failed_writes == 0) return 0;
  log::error(failed_writes,
             " output file(s) could not be written (the previous ones stay whole); every "
             "acknowledged keyframe is in the map store");
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace rgbdmap;
  // First of all: a stop signal during start-up (a supervisor restarting us at once) waits for the clean
  // stop below instead of killing the process before it wrote its outputs.
  const sigset_t stop_signals = blockStopSignals();
  cli::Args args(argc, argv, {"help", "open", "frozen-map"});
  if (args.has("help")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  args.checkAllowed({"config", "map-dir", "transport", "robots", "keys-file", "open", "frozen-map",
                     "status-every", "log-level"});
  std::vector<std::string> errors(args.errors().begin(), args.errors().end());
  const ServerOptions options = parseOptions(args, &errors);
  if (!errors.empty()) return cli::usageError(errors, kUsage);
  logConfiguration("configuration in effect", serverConfigValues(options.config), serverConfigValues({}));
  Result<msg::KeyStore> keys = loadKeys(options.config);
  if (!keys) {
    log::error(keys.error());
    return 2;
  }
  return serve(options, std::move(*keys), stop_signals);
}
