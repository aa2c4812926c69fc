// bench_map_growth: grows one map keyframe by keyframe through a whole MapServer and prints, per
// tenth of the run, what the server spends per keyframe on each of its threads, its pose-graph solves,
// bundle adjustments and octree rebuilds, and its RSS; at the end the keyframes' ATE against the truth.
//
// The world grows: `--rooms-apart` synthetic rooms (SyntheticScene "loop", each its own seed: furniture,
// textures) lie 20 m apart. The robot drives one lap of a room (`--per-lap` keyframes), then the next room,
// and after every `--revisit-every` new rooms one more lap of an earlier room (room r/2), so loops close
// across the whole run, not only within a room. Keyframes are rendered at their true pose (`--width` x
// `--height`, default 320 x 240, to keep rendering off the server's budget), sent as a robot sends them
// (lossless depth, JPEG colour, no features: the server extracts them) with odometry drawn around the truth
// (1 cm and 0.3 deg per keyframe, 1 sigma per axis), over memq:// to a server with fdatasync on. One
// keyframe is in flight at a time (the ingest worker sets the pace). The tenths are taken on the run, as a
// fleet streams: the bench does not wait at their ends, so a tenth carries the background work (optimiser,
// octree rebuilds) done during it. Once the last keyframe is acknowledged the bench waits until the server is
// idle, which includes the global refinement a quiet map gets (whole-graph solve, global BA, the rebuilds
// they cause); its cost is printed on a line of its own ("final"). `--refine-each-tenth` waits like that at
// the end of every tenth instead (what stops 20-27 measured): each tenth then also pays one refinement of
// the whole map, a cost that grows with the map and that a map being grown never pays. Thread CPU comes from
// /proc/self/task (clock ticks, 10 ms); heap_MB is what malloc has handed out and not taken back (mallinfo2,
// every arena), next to the RSS; srv_MB is heap_MB without the bench's rooms.
//   build/bin/bench_map_growth [--keyframes 20000] [--per-lap 60] [--revisit-every 4] [--width 320]
//                              [--height 240] [--no-occupancy] [--max-minutes M] [--map-dir DIR] [--log-info]
//                              [--refine-each-tenth]
// Exits 1 when a keyframe was not acknowledged, the run stopped at --max-minutes or the server did not
// become idle at the end.
#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "bench_common.hpp"
#include "growth_report.hpp"
#include "growth_world.hpp"
#include "process_stats.hpp"
#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/config_reader.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/server/server_config.hpp"
#include "rgbdmap/synth/synth.hpp"

using namespace rgbdmap;
using namespace rgbdmap::bench;

namespace {

struct Options {
  int keyframes = 20000;
  int per_lap = 60;
  int revisit_every = 4;
  int width = 320, height = 240;
  bool occupancy = true;
  bool log_info = false;           ///< the server's info log (global BAs, results that moved many keyframes)
  bool refine_each_tenth = false;  ///< wait for an idle server (global refinement) at the end of each tenth
  double max_minutes = 0.0;
  std::string map_dir;
  std::string config;  ///< YAML whose keys override the bench's server configuration
};

bool parse(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has = i + 1 < argc;
    if (a == "--keyframes" && has) {
      o->keyframes = std::atoi(argv[++i]);
    } else if (a == "--per-lap" && has) {
      o->per_lap = std::atoi(argv[++i]);
    } else if (a == "--revisit-every" && has) {
      o->revisit_every = std::atoi(argv[++i]);
    } else if (a == "--width" && has) {
      o->width = std::atoi(argv[++i]);
    } else if (a == "--height" && has) {
      o->height = std::atoi(argv[++i]);
    } else if (a == "--max-minutes" && has) {
      o->max_minutes = std::atof(argv[++i]);
    } else if (a == "--map-dir" && has) {
      o->map_dir = argv[++i];
    } else if (a == "--config" && has) {
      o->config = argv[++i];
    } else if (a == "--no-occupancy") {
      o->occupancy = false;
    } else if (a == "--log-info") {
      o->log_info = true;
    } else if (a == "--refine-each-tenth") {
      o->refine_each_tenth = true;
    } else {
      return false;
    }
  }
  return o->keyframes >= 10 && o->per_lap >= 8 && o->revisit_every >= 1 && o->width >= 64 &&
         o->height >= 48 && o->width <= 1280 && o->height <= 960 && o->max_minutes >= 0.0;
}

SE3 noisyMotion(const SE3& T, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const double st = 0.01, sr = 0.3 * M_PI / 180.0;
  Vec6 xi;
  xi << st * n(rng), st * n(rng), st * n(rng), sr * n(rng), sr * n(rng), sr * n(rng);
  return T * se3::exp(xi);
}

/// The bench's server configuration with the keys of --config over it; null after errors (printed).
std::optional<MapServerConfig> benchConfig(const Options& o) {
  MapServerConfig config = bench::serverConfig(
      o.map_dir.empty() ? (std::filesystem::temp_directory_path() / "rgbdmap_bench_map_growth").string()
                        : o.map_dir,
      o.occupancy);
  if (o.config.empty()) return config;
  auto reader = ConfigReader::fromFile(o.config);
  if (!reader) {
    std::fprintf(stderr, "bench_map_growth: %s\n", reader.error().c_str());
    return std::nullopt;
  }
  ServerAppConfig app;
  app.server = config;
  readServerConfig(*reader, &app);
  for (const std::string& e : reader->errors())
    std::fprintf(stderr, "bench_map_growth: %s: %s\n", o.config.c_str(), e.c_str());
  if (!reader->errors().empty()) return std::nullopt;
  return app.server;
}

/// The table's rows: per keyframe since the previous row, or totals in ms (the final refinement).
class TenthRows {
 public:
  TenthRows(const MapServer& server, const World& world, double room_mb)
      : server_(server),
        world_(world),
        room_mb_(room_mb),
        cpu_before_(threadCpuByName()),
        before_(server.stats()) {}

  static void printHeader(const Options& o, const std::vector<int>& plan) {
    std::printf(
        "bench_map_growth: %d keyframes, %d per lap, %zu laps over %d rooms (a revisit after every %d), "
        "%dx%d, octree %s, store fdatasync on\n",
        o.keyframes, o.per_lap, plan.size(), *std::max_element(plan.begin(), plan.end()) + 1, o.revisit_every,
        o.width, o.height, o.occupancy ? "on" : "off");
    // oct_lag: keyframes acknowledged but not yet in the octree (the map worker's backlog).
    std::printf("%5s %7s %6s | %s | %6s %8s %6s %8s %5s %8s %7s | %7s %7s %7s %6s\n", "tenth", "kf", "wall_s",
                "CPU ms per keyframe: ingest decode  optim    map rebuild  other", "solves", "solve_ms",
                "globBA", "gBA_ms", "rebld", "rebld_ms", "oct_lag", "RSS_MB", "heap_MB", "srv_MB", "loops");
    std::fflush(stdout);
  }

  void print(const std::string& label, bool per_keyframe = true) {
    const auto now = std::chrono::steady_clock::now();
    const std::map<std::string, double> cpu = threadCpuByName();
    const MapServerStats s = server_.stats();
    const int n = per_keyframe ? s.keyframes - before_.keyframes : 1;
    const auto per = [&](const std::string& name) {
      const auto a = cpu.find(name);
      const auto b = cpu_before_.find(name);
      const double d = (a == cpu.end() ? 0.0 : a->second) - (b == cpu_before_.end() ? 0.0 : b->second);
      return n > 0 ? 1e3 * d / n : 0.0;
    };
    std::printf(
        "%5s %7d %6.0f | %28.1f %6.1f %6.1f %6.1f %7.1f %6.1f | %6d %8.0f %6lld %8.0f %5llu %8.0f %7lld | "
        "%7.0f %7.0f %7.0f %6d\n",
        label.c_str(), s.keyframes, std::chrono::duration<double>(now - t_row_).count(),
        per("rgbdmap-ingest"), per("rgbdmap-decode"), per("rgbdmap-optim"), per("rgbdmap-map"),
        per("rgbdmap-rebuild"), per("other") + per("rgbdmap-status") + per("rgbdmap-store"),
        s.graph_solves - before_.graph_solves, s.last_optimize_ms,
        static_cast<long long>(s.ba.global_runs - before_.ba.global_runs), s.ba.global_ms_last,
        static_cast<unsigned long long>(s.map_rebuilds - before_.map_rebuilds), s.map_last_rebuild_ms,
        static_cast<long long>(s.keyframes) - static_cast<long long>(s.map_keyframes), rssMb(), heapInUseMb(),
        heapInUseMb() - room_mb_ * static_cast<double>(world_.roomsKept()), s.loops_accepted);
    std::fflush(stdout);
    cpu_before_ = cpu;
    before_ = s;
    t_row_ = now;
  }

 private:
  const MapServer& server_;
  const World& world_;
  double room_mb_;  ///< the bench's heap per room kept (taken off heap_MB for srv_MB)
  std::map<std::string, double> cpu_before_;
  MapServerStats before_;
  std::chrono::steady_clock::time_point t_row_ = std::chrono::steady_clock::now();
};

/// What the robot sent: the true and the odometry trajectories, keyframes sent and not acknowledged.
struct Stream {
  Trajectory truth, odometry;
  SE3 T_odom = SE3::Identity(), T_world_prev = SE3::Identity();
  std::mt19937 rng{17};
  int sent = 0, unacked = 0;
  bool out_of_time = false;
};

/// Keyframe `stream->sent` at T_world_cam, with odometry drawn around the truth; null when encoding failed.
std::optional<msg::Keyframe> nextKeyframe(const RgbdFrame& frame, const SE3& T_world_cam, Stream* stream) {
  msg::Keyframe kf;
  kf.robot_id = "robot0";
  kf.keyframe_id = stream->sent;
  kf.timestamp = 1000.0 + stream->sent;  // one keyframe per second
  if (stream->sent > 0) {
    kf.previous_keyframe_id = stream->sent - 1;
    kf.T_prev_cur = noisyMotion(stream->T_world_prev.inverse() * T_world_cam, stream->rng);
    kf.information.setZero();
    kf.information.diagonal() << Vec3::Constant(1e4), Vec3::Constant(1.0 / std::pow(0.3 * M_PI / 180, 2));
    stream->T_odom = stream->T_odom * kf.T_prev_cur;
  }
  kf.T_odom_cam = stream->T_odom;
  auto images = encodeImages(frame);
  if (!images) {
    std::fprintf(stderr, "bench_map_growth: encode: %s\n", images.error().c_str());
    return std::nullopt;
  }
  kf.images = std::move(*images);
  stream->truth.push_back({kf.timestamp, T_world_cam});
  stream->odometry.push_back({kf.timestamp, stream->T_odom});
  stream->T_world_prev = T_world_cam;
  return kf;
}

/// The laps of the plan, keyframe by keyframe, each sent once acknowledged (a row per tenth). False when a
/// room or a keyframe could not be made.
bool streamLaps(const Options& o, const std::vector<int>& plan, World& world, MapServer& server,
                transport::Transport& transport, bench::AckWaiter& acks, msg::Signer& signer, TenthRows& rows,
                Stream* stream) {
  const auto t_start = std::chrono::steady_clock::now();
  const int tenth = std::max(1, o.keyframes / 10);
  for (size_t lap = 0; lap < plan.size() && stream->sent < o.keyframes && !stream->out_of_time; ++lap) {
    const SyntheticScene* room = world.room(plan[lap]);
    if (!room) return false;
    for (int i = 0; i < o.per_lap && stream->sent < o.keyframes; ++i) {
      const SE3 T_world_cam = World::T_world_room(plan[lap]) * room->trajectory()[i].T_world_cam;
      const std::optional<msg::Keyframe> kf = nextKeyframe(room->renderFrame(i), T_world_cam, stream);
      if (!kf) return false;
      (void)transport.publish(*msg::channelFor(msg::MessageType::kKeyframe, "robot0"),
                              signer.seal(*kf, 1).value());
      if (!acks.waitFor(stream->sent, 120.0)) ++stream->unacked;
      ++stream->sent;
      const double minutes =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() / 60;
      if (o.max_minutes > 0 && minutes > o.max_minutes) stream->out_of_time = true;
      if (stream->sent % tenth != 0 && stream->sent != o.keyframes && !stream->out_of_time) continue;
      if (o.refine_each_tenth) server.waitIdle(1800.0);
      rows.print(std::to_string(stream->sent / tenth));
      if (stream->out_of_time) break;
    }
  }
  return true;
}

/// The ATE of the server's keyframes and of the odometry, and the run's end line.
void printEnd(const MapServer& server, const Stream& stream) {
  Trajectory estimate;
  for (const ServerKeyframe& k : server.keyframes()) estimate.push_back({k.timestamp, k.T_map_kf});
  const auto ate = computeAte(stream.truth, estimate);
  const auto ate_odometry = computeAte(stream.truth, stream.odometry);
  const MapServerStats s = server.stats();
  std::printf(
      "end: %d keyframes sent, %d stored, %d not acknowledged; loops %d (disabled %d), solves %d (%d kept "
      "without one), global BA %lld; BA parts kept in place %lld (largest %.3f m), BAs refused %lld; ATE %s "
      "m "
      "(odometry %s m)%s\n",
      stream.sent, s.keyframes, stream.unacked, s.loops_accepted, s.loops_disabled, s.graph_solves,
      s.graph_solves_skipped, static_cast<long long>(s.ba.global_runs),
      static_cast<long long>(s.ba.parts_kept), s.ba.part_shift_m_max, static_cast<long long>(s.ba.refused),
      ate ? std::to_string(ate->rmse).c_str() : ate.error().c_str(),
      ate_odometry ? std::to_string(ate_odometry->rmse).c_str() : ate_odometry.error().c_str(),
      stream.out_of_time ? "; stopped at --max-minutes" : "");
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse(argc, argv, &o)) {
    std::fprintf(stderr,
                 "usage: bench_map_growth [--keyframes N>=10] [--per-lap K>=8] [--revisit-every R>=1] "
                 "[--width W] [--height H] [--no-occupancy] [--max-minutes M] [--map-dir DIR] [--config FILE "
                 "(server.yaml keys to override)] [--log-info] [--refine-each-tenth]\n");
    return 2;
  }
  cv::setNumThreads(1);
  log::setLevel(o.log_info ? log::Level::kInfo : log::Level::kWarn);
  World world(o.per_lap, o.width, o.height);
  // A room's textures take ~100 MB of the bench's own heap (up to 4 rooms are kept): measured once here,
  // before the server starts, and taken off the heap to give the server's share (srv_MB).
  const double heap_before_room = heapInUseMb();
  if (!world.room(0)) return 1;
  const double room_mb = heapInUseMb() - heap_before_room;
  const std::vector<int> plan = lapPlan((o.keyframes + o.per_lap - 1) / o.per_lap, o.revisit_every);

  auto transport = std::move(transport::makeTransport("memq://").value());
  const std::optional<MapServerConfig> config = benchConfig(o);
  if (!config) return 2;
  std::filesystem::remove_all(config->map_dir);
  MapServer server(*config, *transport, msg::KeyStore::openMode());
  if (!server.start() || !transport->start()) return 1;
  bench::AckWaiter acks(*transport);
  msg::Signer signer("robot0", {});
  bench::sayHello(*transport, signer, world.camera());
  TenthRows::printHeader(o, plan);
  TenthRows rows(server, world, room_mb);
  Stream stream;
  if (!streamLaps(o, plan, world, server, *transport, acks, signer, rows, &stream)) return 1;
  // What the map has left once the robot stops: the background work still queued, then the global
  // refinement of a quiet map (whole-graph solve, global BA) and the rebuilds it causes. In ms, not per
  // keyframe (a cost paid once per quiet period, not per keyframe).
  const double peak_streaming_mb = statusMb("VmHWM:");  // the peak RSS while the keyframes came
  const bool idle = server.waitIdle(1800.0);
  if (!idle) std::fprintf(stderr, "bench_map_growth: the server did not become idle within 30 min\n");
  printServerTotals(server.stats());
  std::printf("final refinement after the last keyframe, CPU ms in total (not per keyframe):\n");
  rows.print("final", false);
  printMapWorker(server.stats());
  Trajectory estimate;
  for (const ServerKeyframe& k : server.keyframes()) estimate.push_back({k.timestamp, k.T_map_kf});
  printLapAte(stream.truth, estimate, o.per_lap, plan);
  std::printf("peak RSS (VmHWM): %.0f MB while the keyframes came, %.0f MB over the whole run\n",
              peak_streaming_mb, statusMb("VmHWM:"));
  printEnd(server, stream);
  printLoopsAgainstTruth(server, stream.truth, o.per_lap, plan);
  transport->stop();
  server.stop();
  if (o.map_dir.empty()) std::filesystem::remove_all(config->map_dir);
  return stream.unacked == 0 && !stream.out_of_time && idle ? 0 : 1;
}
