// Server ingest benchmark: keyframes of a real (fr1_rpy, when ../shared/data is there) or synthetic sequence
// go one at a time through a MapServer over memq:// with durable storage on; prints the server's per-keyframe
// ingest time (decode + store + candidates + verification + graph) and its stages, then the occupancy map's
// numbers (octree insertion and slice extraction on the map worker, tree size, rebuilds, map files). Odometry
// and image encoding happen before the clock starts. `--no-occupancy` turns the octree off (A/B comparison).
// Keyframes are sent as the robot's default sends them, without features (the server extracts them:
// "decode+features" below); `--robot-features` sends the odometry's features instead.
// Run on one core: taskset -c 1 build/bin/bench_map_server
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <set>
#include <string>

#include <opencv2/core.hpp>

#include "bench_common.hpp"
#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

using namespace rgbdmap;

namespace {

struct Sequence {
  std::string name;
  CameraIntrinsics camera;
  std::vector<msg::Keyframe> keyframes;
};

Sequence prepare(bool robot_features) {
  Sequence seq;
  const std::string tum = std::string(RGBDMAP_SHARED_DATA_DIR) + "/tum_fr1_rpy_first250";
  std::vector<RgbdFrame> frames;
  if (auto d = TumDataset::open(tum)) {
    seq.name = "tum_fr1_rpy_first250";
    for (size_t i = 0; i < d->size(); ++i)
      if (auto f = d->load(i)) frames.push_back(*f);
  } else {
    seq.name = "synthetic loop, 300 frames";
    SynthConfig cfg;
    seq.camera = cfg.camera;
    auto scene = SyntheticScene::build(cfg);
    for (int i = 0; scene && i < cfg.frames; ++i) frames.push_back(scene->renderFrame(i));
  }
  VisualOdometry vo(seq.camera, OdometryConfig{});
  for (const RgbdFrame& f : frames) {
    const TrackingResult r = vo.track(f);
    if (!r.new_keyframe) continue;
    auto images = encodeImages(f);
    auto m = images ? keyframeToMessage(*r.new_keyframe, "robot0", *images, robot_features)
                    : Result<msg::Keyframe>::failure("");
    if (m) seq.keyframes.push_back(*m);
  }
  return seq;
}

/// The sequence's keyframes one at a time (each acknowledged and through the map worker); the wall time (s).
double sendOneAtATime(const Sequence& seq, MapServer& server, transport::Transport& transport) {
  bench::AckWaiter acks(transport);
  msg::Signer signer("robot0", {});
  bench::sayHello(transport, signer, seq.camera);
  const auto t0 = std::chrono::steady_clock::now();
  for (const msg::Keyframe& kf : seq.keyframes) {
    (void)transport.publish(*msg::channelFor(msg::MessageType::kKeyframe, "robot0"),
                            signer.seal(kf, 1).value());
    (void)acks.waitFor(kf.keyframe_id, 30.0);
    server.waitIdle(30.0);  // one keyframe at a time (its octree insertion too): no queueing in the numbers
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void printIngest(const Sequence& seq, const MapServerStats& s, bool occupancy, bool robot_features,
                 double wall) {
  std::printf(
      "bench_map_server: %s, %d keyframes, store fdatasync on, one keyframe in flight, octree %s, features "
      "%s\n",
      seq.name.c_str(), s.keyframes, occupancy ? "on" : "off (--no-occupancy)",
      robot_features ? "sent by the robot (--robot-features)" : "extracted by the server");
  std::printf(
      "  ingest per keyframe   median %6.1f ms  p90 %6.1f ms  max %6.1f ms   (target: median <= 30 ms)\n",
      s.ingest_ms_median, s.ingest_ms_p90, s.ingest_ms_max);
  std::printf("  ingest CPU time       median %6.1f ms  p90 %6.1f ms   (the worker thread's own CPU time)\n",
              s.ingest_cpu_ms_median, s.ingest_cpu_ms_p90);
  std::printf(
      "  stages (median)       decode+features %.1f ms, store %.1f ms, loops+graph %.1f ms (verification "
      "%.1f ms)\n",
      s.decode_ms_median, s.store_ms_median, s.loops_ms_median, s.verify_ms_median);
  std::printf(
      "  decode thread         median %6.1f ms CPU per keyframe, %llu of %llu decoded there (not in the "
      "ingest CPU time)\n",
      s.decode_cpu_ms_median, static_cast<unsigned long long>(s.keyframes_decoded_ahead),
      static_cast<unsigned long long>(s.keyframes_decoded));
  std::printf("  loops accepted %d (disabled %d), candidates %d, optimisations %d (last %.1f ms)\n",
              s.loops_accepted, s.loops_disabled, s.loop_candidates, s.optimizations, s.last_optimize_ms);
  std::printf("  wall %.2f s for the sequence (%.1f keyframes/s including acknowledgements and octree)\n",
              wall, s.keyframes / wall);
}

/// The occupancy map's numbers, with the map files written to `out`.
void printOccupancy(MapServer& server, const MapServerConfig& config, const MapServerStats& s,
                    const std::string& out) {
  const auto t_out = std::chrono::steady_clock::now();
  const Status written = server.writeMapOutputs(out);
  const double out_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_out).count();
  const auto size_kb = [&](const char* name) {
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(out + "/" + name, ec);
    return ec ? -1.0 : static_cast<double>(bytes) / 1e3;
  };
  std::printf("occupancy map (%.2f m, on the map worker thread, not in the ingest time above):\n",
              config.occupancy.resolution_m);
  std::printf(
      "  octree insertion      median %6.1f ms CPU per keyframe (cloud reduction + insertion), %zu "
      "keyframes\n",
      s.map_insert_ms_median, s.map_keyframes);
  std::printf("  slice extraction      median %6.2f ms CPU (%.0f m x %.0f m at %.2f m), %llu slices sent\n",
              s.slice_ms_median, config.slice.size_m, config.slice.size_m, config.slice.resolution_m,
              static_cast<unsigned long long>(s.slices_sent));
  std::printf("  tree                  %zu leaves (%zu occupied), %.2f MB in memory; kept clouds %.2f MB\n",
              s.map_leaves, s.map_occupied_leaves, s.map_tree_memory_bytes / 1e6,
              s.map_clouds_memory_bytes / 1e6);
  std::printf("  rebuilds              %llu (last %.0f ms)\n",
              static_cast<unsigned long long>(s.map_rebuilds), s.map_last_rebuild_ms);
  std::printf("  map stream            %llu updates, %.1f KB (zstd)\n",
              static_cast<unsigned long long>(s.map_updates_sent), s.map_bytes_sent / 1e3);
  std::printf(
      "  map files             %s in %.0f ms: map.bt %.1f KB, map.ot %.1f KB, map.ply %.1f KB, map.png %.1f "
      "KB\n",
      written ? "written" : written.error().c_str(), out_ms, size_kb("map.bt"), size_kb("map.ot"),
      size_kb("map.ply"), size_kb("map.png"));
}

}  // namespace

int main(int argc, char** argv) {
  bool occupancy = true, robot_features = false;  // A/B switches on a shared machine
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--no-occupancy") {
      occupancy = false;
    } else if (a == "--robot-features") {
      robot_features = true;
    } else {
      std::fprintf(stderr, "usage: bench_map_server [--no-occupancy] [--robot-features]\n");
      return 2;
    }
  }
  cv::setNumThreads(1);
  log::setLevel(log::Level::kWarn);
  const Sequence seq = prepare(robot_features);
  auto transport = std::move(transport::makeTransport("memq://").value());
  MapServerConfig config = bench::serverConfig(
      (std::filesystem::temp_directory_path() / "rgbdmap_bench_map_server").string(), occupancy);
  std::filesystem::remove_all(config.map_dir);
  MapServer server(config, *transport, msg::KeyStore::openMode());
  if (!server.start() || !transport->start()) return 1;
  const double wall = sendOneAtATime(seq, server, *transport);
  server.waitIdle(60.0);
  const MapServerStats s = server.stats();
  printIngest(seq, s, occupancy, robot_features, wall);
  const std::string out = config.map_dir + "_out";
  if (occupancy) printOccupancy(server, config, s, out);
  transport->stop();
  server.stop();
  std::filesystem::remove_all(config.map_dir);
  if (occupancy) std::filesystem::remove_all(out);
  return 0;
}
