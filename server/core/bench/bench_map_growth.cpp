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
#include <dirent.h>
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bench_common.hpp"
#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/config_reader.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/server/server_config.hpp"
#include "rgbdmap/synth/synth.hpp"

using namespace rgbdmap;

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

/// The rooms of the world, built on demand (a room is deterministic by its seed) and kept a few at a time.
class World {
 public:
  World(int per_lap, int width, int height) : per_lap_(per_lap) {
    const double s = width / 640.0;
    camera_ = {525.0 * s,
               525.0 * (height / 480.0),
               (width - 1) / 2.0,
               (height - 1) / 2.0,
               width,
               height,
               {0.0, 0.0, 0.0, 0.0, 0.0},
               5000.0};
  }
  const CameraIntrinsics& camera() const { return camera_; }
  size_t roomsKept() const { return rooms_.size(); }
  const SyntheticScene* room(int r) {
    if (auto it = rooms_.find(r); it != rooms_.end()) return it->second.get();
    if (rooms_.size() >= 4) rooms_.erase(rooms_.begin());  // the oldest ids: revisits go back to r/2
    SynthConfig c;
    c.scene = "loop";
    c.frames = per_lap_;
    c.seed = static_cast<uint64_t>(r) + 1;
    c.camera = camera_;
    auto scene = SyntheticScene::build(c);
    if (!scene) {
      std::fprintf(stderr, "bench_map_growth: room %d: %s\n", r, scene.error().c_str());
      return nullptr;
    }
    return rooms_.emplace(r, std::make_unique<SyntheticScene>(std::move(*scene))).first->second.get();
  }
  /// Where room r lies in the world.
  static SE3 T_world_room(int r) {
    SE3 T = SE3::Identity();
    T.translation() = Vec3(20.0 * r, 0.0, 0.0);
    return T;
  }

 private:
  int per_lap_;
  CameraIntrinsics camera_;
  std::map<int, std::unique_ptr<SyntheticScene>> rooms_;
};

/// Room of each lap: 0, 1, ..., with a lap of room r/2 after every `revisit_every` new rooms.
std::vector<int> lapPlan(int laps, int revisit_every) {
  std::vector<int> plan;
  for (int r = 0; static_cast<int>(plan.size()) < laps; ++r) {
    plan.push_back(r);
    if (r > 0 && r % revisit_every == 0) plan.push_back(r / 2);
  }
  plan.resize(laps);
  return plan;
}

/// CPU seconds of each of this process's threads, summed by thread name.
std::map<std::string, double> threadCpuByName() {
  std::map<std::string, double> cpu;
  const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
  DIR* dir = opendir("/proc/self/task");
  if (!dir) return cpu;
  while (dirent* e = readdir(dir)) {
    if (e->d_name[0] == '.') continue;
    const std::string base = std::string("/proc/self/task/") + e->d_name;
    std::ifstream comm(base + "/comm"), stat(base + "/stat");
    std::string name, line;
    if (!std::getline(comm, name) || !std::getline(stat, line)) continue;
    const size_t close = line.rfind(')');  // the name in stat may hold spaces
    if (close == std::string::npos) continue;
    std::istringstream fields(line.substr(close + 2));
    std::string f;
    double utime = 0.0, stime = 0.0;
    for (int k = 3; k <= 15 && fields >> f; ++k) {  // field 3 is the state; 14 utime, 15 stime
      if (k == 14) utime = std::atof(f.c_str());
      if (k == 15) stime = std::atof(f.c_str());
    }
    cpu[name.rfind("rgbdmap-", 0) == 0 ? name : "other"] += (utime + stime) / tick;
  }
  closedir(dir);
  return cpu;
}

/// A field of /proc/self/status in MB ("VmRSS:" now, "VmHWM:" the peak so far).
double statusMb(const char* field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  const size_t n = std::strlen(field);
  while (std::getline(status, line))
    if (line.compare(0, n, field) == 0) return std::atof(line.c_str() + n) / 1024.0;
  return 0.0;
}

double rssMb() { return statusMb("VmRSS:"); }

/// Bytes the process's heap has handed out and not freed (every malloc arena and mmapped chunks): RSS
/// minus this is freed memory the allocator keeps, code, stacks and the rendering's textures.
double heapInUseMb() {
  const struct mallinfo2 m = mallinfo2();
  return static_cast<double>(m.uordblks + m.hblkhd) / (1024.0 * 1024.0);
}

SE3 noisyMotion(const SE3& T, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const double st = 0.01, sr = 0.3 * M_PI / 180.0;
  Vec6 xi;
  xi << st * n(rng), st * n(rng), st * n(rng), sr * n(rng), sr * n(rng), sr * n(rng);
  return T * se3::exp(xi);
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
  MapServerConfig config = bench::serverConfig(
      o.map_dir.empty() ? (std::filesystem::temp_directory_path() / "rgbdmap_bench_map_growth").string()
                        : o.map_dir,
      o.occupancy);
  if (!o.config.empty()) {
    auto reader = ConfigReader::fromFile(o.config);
    if (!reader) {
      std::fprintf(stderr, "bench_map_growth: %s\n", reader.error().c_str());
      return 2;
    }
    ServerAppConfig app;
    app.server = config;
    readServerConfig(*reader, &app);
    for (const std::string& e : reader->errors())
      std::fprintf(stderr, "bench_map_growth: %s: %s\n", o.config.c_str(), e.c_str());
    if (!reader->errors().empty()) return 2;
    config = app.server;
  }
  std::filesystem::remove_all(config.map_dir);
  MapServer server(config, *transport, msg::KeyStore::openMode());
  if (!server.start() || !transport->start()) return 1;

  bench::AckWaiter acks(*transport);
  msg::Signer signer("robot0", {});
  bench::sayHello(*transport, signer, world.camera());

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

  std::mt19937 rng(17);
  Trajectory truth, odometry;
  SE3 T_odom = SE3::Identity(), T_world_prev = SE3::Identity();
  const auto t_start = std::chrono::steady_clock::now();
  auto t_tenth = t_start;
  std::map<std::string, double> cpu_before = threadCpuByName();
  MapServerStats before = server.stats();
  int sent = 0, unacked = 0;
  bool out_of_time = false;
  const int tenth = std::max(1, o.keyframes / 10);
  // One row: per keyframe since the previous row (per_keyframe), or totals in ms (the final refinement).
  const auto printRow = [&](const std::string& label, bool per_keyframe = true) {
    const auto now = std::chrono::steady_clock::now();
    const std::map<std::string, double> cpu = threadCpuByName();
    const MapServerStats s = server.stats();
    const int n = per_keyframe ? s.keyframes - before.keyframes : 1;
    const auto per = [&](const std::string& name) {
      const auto a = cpu.find(name);
      const auto b = cpu_before.find(name);
      const double d = (a == cpu.end() ? 0.0 : a->second) - (b == cpu_before.end() ? 0.0 : b->second);
      return n > 0 ? 1e3 * d / n : 0.0;
    };
    std::printf(
        "%5s %7d %6.0f | %28.1f %6.1f %6.1f %6.1f %7.1f %6.1f | %6d %8.0f %6lld %8.0f %5llu %8.0f %7lld | "
        "%7.0f %7.0f %7.0f %6d\n",
        label.c_str(), s.keyframes, std::chrono::duration<double>(now - t_tenth).count(),
        per("rgbdmap-ingest"), per("rgbdmap-decode"), per("rgbdmap-optim"), per("rgbdmap-map"),
        per("rgbdmap-rebuild"), per("other") + per("rgbdmap-status") + per("rgbdmap-store"),
        s.graph_solves - before.graph_solves, s.last_optimize_ms,
        static_cast<long long>(s.ba.global_runs - before.ba.global_runs), s.ba.global_ms_last,
        static_cast<unsigned long long>(s.map_rebuilds - before.map_rebuilds), s.map_last_rebuild_ms,
        static_cast<long long>(s.keyframes) - static_cast<long long>(s.map_keyframes), rssMb(), heapInUseMb(),
        heapInUseMb() - room_mb * static_cast<double>(world.roomsKept()), s.loops_accepted);
    std::fflush(stdout);
    cpu_before = cpu;
    before = s;
    t_tenth = now;
  };
  for (size_t lap = 0; lap < plan.size() && sent < o.keyframes && !out_of_time; ++lap) {
    const SyntheticScene* room = world.room(plan[lap]);
    if (!room) return 1;
    for (int i = 0; i < o.per_lap && sent < o.keyframes; ++i) {
      const RgbdFrame frame = room->renderFrame(i);
      const SE3 T_world_cam = World::T_world_room(plan[lap]) * room->trajectory()[i].T_world_cam;
      msg::Keyframe kf;
      kf.robot_id = "robot0";
      kf.keyframe_id = sent;
      kf.timestamp = 1000.0 + sent;  // one keyframe per second
      if (sent > 0) {
        kf.previous_keyframe_id = sent - 1;
        kf.T_prev_cur = noisyMotion(T_world_prev.inverse() * T_world_cam, rng);
        kf.information.setZero();
        kf.information.diagonal() << Vec3::Constant(1e4), Vec3::Constant(1.0 / std::pow(0.3 * M_PI / 180, 2));
        T_odom = T_odom * kf.T_prev_cur;
      }
      kf.T_odom_cam = T_odom;
      auto images = encodeImages(frame);
      if (!images) {
        std::fprintf(stderr, "bench_map_growth: encode: %s\n", images.error().c_str());
        return 1;
      }
      kf.images = std::move(*images);
      truth.push_back({kf.timestamp, T_world_cam});
      odometry.push_back({kf.timestamp, T_odom});
      T_world_prev = T_world_cam;
      (void)transport->publish(*msg::channelFor(msg::MessageType::kKeyframe, "robot0"),
                               signer.seal(kf, 1).value());
      if (!acks.waitFor(sent, 120.0)) ++unacked;
      ++sent;
      const double minutes =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count() / 60;
      if (o.max_minutes > 0 && minutes > o.max_minutes) out_of_time = true;
      if (sent % tenth != 0 && sent != o.keyframes && !out_of_time) continue;
      if (o.refine_each_tenth) server.waitIdle(1800.0);
      printRow(std::to_string(sent / tenth));
      if (out_of_time) break;
    }
  }
  // What the map has left once the robot stops: the background work still queued, then the global
  // refinement of a quiet map (whole-graph solve, global BA) and the rebuilds it causes. In ms, not per
  // keyframe (a cost paid once per quiet period, not per keyframe).
  const double peak_streaming_mb = statusMb("VmHWM:");  // the peak RSS while the keyframes came
  const bool idle = server.waitIdle(1800.0);
  if (!idle) std::fprintf(stderr, "bench_map_growth: the server did not become idle within 30 min\n");
  {
    const MapServerStats l = server.stats();
    std::printf(
        "loop candidates verified: %d, matched all against all: %d without a prior pose, %d after too few "
        "matches by projection (%d of those verified; %d more rejected without it, "
        "loop.max_fallbacks_per_keyframe)\n",
        l.loop_candidates, l.loop_brute_force_no_prior, l.loop_brute_force_fallback,
        l.loop_brute_force_fallback_verified, l.loop_fallbacks_skipped);
    std::printf(
        "keyframe features: %zu in RAM (server.features_in_memory), %llu read back from the store, %llu "
        "reads failed, %d loop candidates skipped for them\n",
        l.features_resident, static_cast<unsigned long long>(l.features_loads),
        static_cast<unsigned long long>(l.features_load_failures), l.loop_features_unavailable);
    const LandmarkStats& lm = l.ba.landmarks;
    std::printf(
        "landmark tracks: %lld keyframes, %lld landmarks, %lld observations (%.1f per landmark), %.0f MB; "
        "retrieval index %.0f MB (%.1f KB per keyframe)\n",
        static_cast<long long>(lm.keyframes), static_cast<long long>(lm.landmarks),
        static_cast<long long>(lm.observations),
        lm.landmarks > 0 ? static_cast<double>(lm.observations) / static_cast<double>(lm.landmarks) : 0.0,
        static_cast<double>(lm.memory_bytes) / 1e6, static_cast<double>(l.retrieval_index_bytes) / 1e6,
        l.keyframes > 0 ? static_cast<double>(l.retrieval_index_bytes) / 1e3 / l.keyframes : 0.0);
    std::printf(
        "freed heap given back (server.memory_trim_period_s): %llu trims, %.0f MB released, %.0f ms CPU\n",
        static_cast<unsigned long long>(l.memory_trims),
        static_cast<double>(l.memory_trim_released_bytes) / 1e6, l.memory_trim_cpu_ms);
  }
  std::printf("final refinement after the last keyframe, CPU ms in total (not per keyframe):\n");
  printRow("final", false);
  {
    const MapServerStats m = server.stats();
    std::printf(
        "map worker: octree insertion %.1f ms CPU per keyframe (median), slice %.1f ms (median, %llu sent), "
        "%llu keyframes queued without their images (read back from the store: the worker was behind), %llu "
        "pose updates replaced by a newer one before they were applied, %llu "
        "map updates (%.1f MB); kept clouds %.0f MB in RAM, %zu spilled (file %.0f MB, %llu failures), "
        "octrees %.0f MB, stream journals %.0f MB\n",
        m.map_insert_ms_median, m.slice_ms_median, static_cast<unsigned long long>(m.slices_sent),
        static_cast<unsigned long long>(m.map_images_deferred),
        static_cast<unsigned long long>(m.map_pose_updates_coalesced),
        static_cast<unsigned long long>(m.map_updates_sent), static_cast<double>(m.map_bytes_sent) / 1e6,
        static_cast<double>(m.map_clouds_memory_bytes) / 1e6, m.map_clouds_spilled,
        static_cast<double>(m.map_spill_file_bytes) / 1e6,
        static_cast<unsigned long long>(m.map_spill_failures),
        static_cast<double>(m.map_tree_memory_bytes) / 1e6, static_cast<double>(m.map_journal_bytes) / 1e6);
  }
  Trajectory estimate;
  for (const ServerKeyframe& k : server.keyframes()) estimate.push_back({k.timestamp, k.T_map_kf});
  const auto ate = computeAte(truth, estimate);
  const auto ate_odometry = computeAte(truth, odometry);
  // The jumps between rooms are blind (no overlap, one noisy odometry step of up to hundreds of metres), so
  // the global ATE grows with the number of rooms whatever the server does. What the server's optimisation
  // decides is each lap's shape: the ATE of each lap aligned on its own, over the first and the last tenth
  // of the laps, shows whether the map's accuracy holds as it grows.
  // Each lap's ATE (aligned on its own); -1 when it has too few poses.
  const size_t laps_run = (truth.size() + o.per_lap - 1) / o.per_lap;
  std::vector<double> lap_ate(laps_run, -1.0);
  for (size_t lap = 0; lap < laps_run; ++lap) {
    Trajectory t, e;
    for (size_t i = lap * o.per_lap; i < std::min(truth.size(), (lap + 1) * o.per_lap); ++i)
      t.push_back(truth[i]);
    if (t.size() < 8) continue;
    for (const auto& p : estimate)
      if (p.timestamp >= t.front().timestamp && p.timestamp <= t.back().timestamp) e.push_back(p);
    if (e.size() < 8) continue;
    if (const auto a = computeAte(t, e)) lap_ate[lap] = a->rmse;
  }
  const auto lapAte = [&](size_t first, size_t last) {
    double sum = 0.0;
    int n = 0;
    for (size_t lap = first; lap < last; ++lap)
      if (lap_ate[lap] >= 0.0) sum += lap_ate[lap], ++n;
    return n > 0 ? sum / n : -1.0;
  };
  const size_t lap_tenth = std::max<size_t>(1, laps_run / 10);
  std::printf(
      "per-lap ATE (each lap aligned on its own), mean: first tenth %.4f m, last tenth %.4f m, all %.4f m\n",
      lapAte(0, lap_tenth), lapAte(laps_run - std::min(laps_run, lap_tenth), laps_run), lapAte(0, laps_run));
  std::vector<size_t> worst(laps_run);
  for (size_t i = 0; i < laps_run; ++i) worst[i] = i;
  std::sort(worst.begin(), worst.end(), [&](size_t a, size_t b) { return lap_ate[a] > lap_ate[b]; });
  std::printf("worst laps (lap:room ATE):");
  for (size_t k = 0; k < std::min<size_t>(8, worst.size()); ++k)
    std::printf(" %zu:%d %.3f m", worst[k], plan[worst[k]], lap_ate[worst[k]]);
  std::printf("\n");
  std::printf("peak RSS (VmHWM): %.0f MB while the keyframes came, %.0f MB over the whole run\n",
              peak_streaming_mb, statusMb("VmHWM:"));
  const MapServerStats s = server.stats();
  std::printf(
      "end: %d keyframes sent, %d stored, %d not acknowledged; loops %d (disabled %d), solves %d (%d kept "
      "without one), global BA %lld; BA parts kept in place %lld (largest %.3f m), BAs refused %lld; ATE %s "
      "m "
      "(odometry %s m)%s\n",
      sent, s.keyframes, unacked, s.loops_accepted, s.loops_disabled, s.graph_solves, s.graph_solves_skipped,
      static_cast<long long>(s.ba.global_runs), static_cast<long long>(s.ba.parts_kept),
      s.ba.part_shift_m_max, static_cast<long long>(s.ba.refused),
      ate ? std::to_string(ate->rmse).c_str() : ate.error().c_str(),
      ate_odometry ? std::to_string(ate_odometry->rmse).c_str() : ate_odometry.error().c_str(),
      out_of_time ? "; stopped at --max-minutes" : "");
  // Every loop against the truth: one far from the true relative pose is a false match; the consistency
  // check should hold it out (enabled false).
  std::map<int64_t, int> index_of_node;
  for (const ServerKeyframe& k : server.keyframes()) index_of_node[k.node_id] = k.keyframe_id;
  int checked = 0, wrong = 0, wrong_enabled = 0, true_disabled = 0;
  std::vector<std::pair<double, std::string>> worst_loops;  // false loops still enabled
  for (const ServerLoop& l : server.loops()) {
    const auto a = index_of_node.find(l.from_node), b = index_of_node.find(l.to_node);
    if (a == index_of_node.end() || b == index_of_node.end() || a->second >= static_cast<int>(truth.size()) ||
        b->second >= static_cast<int>(truth.size()))
      continue;
    const SE3 d =
        (truth[a->second].T_world_cam.inverse() * truth[b->second].T_world_cam).inverse() * l.T_from_to;
    const double dt = d.translation().norm();
    const double dr = Eigen::AngleAxisd(d.rotation()).angle() * 180.0 / M_PI;
    ++checked;
    const bool is_false = dt > 0.05 || dr > 2.0;
    wrong += is_false ? 1 : 0;
    true_disabled += !is_false && !l.enabled ? 1 : 0;
    if (!is_false || !l.enabled) continue;
    ++wrong_enabled;
    char line[160];
    std::snprintf(line, sizeof line, " %d(lap %d room %d)-%d(lap %d room %d) %.2f m %.1f deg", a->second,
                  a->second / o.per_lap, plan[a->second / o.per_lap], b->second, b->second / o.per_lap,
                  plan[b->second / o.per_lap], dt, dr);
    worst_loops.emplace_back(dt + dr / 10.0, line);
  }
  std::sort(worst_loops.rbegin(), worst_loops.rend());
  std::printf(
      "loops against the truth: %d checked, %d false (off by > 5 cm or 2 deg) of which %d enabled at the "
      "end, "
      "%d true ones disabled%s",
      checked, wrong, wrong_enabled, true_disabled, wrong_enabled > 0 ? "; worst enabled:" : "");
  for (size_t k = 0; k < std::min<size_t>(6, worst_loops.size()); ++k)
    std::printf("%s", worst_loops[k].second.c_str());
  std::printf("\n");
  transport->stop();
  server.stop();
  if (o.map_dir.empty()) std::filesystem::remove_all(config.map_dir);
  return unacked == 0 && !out_of_time && idle ? 0 : 1;
}
