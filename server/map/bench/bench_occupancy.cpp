// bench_occupancy: the occupancy map's costs on TUM fr1_rpy (first 250 frames, every 3rd one a keyframe at
// its ground-truth pose, map frame = first keyframe's camera; synthetic 640x480 loop frames when the data is
// absent). Targets: insertion <= 30 ms per keyframe at 0.05 m on one core, slice 8 x 8 m at 0.05 m <= 5 ms.
//   taskset -c 1 build/bin/bench_occupancy
// Counters: cpu_ms_per_kf (insertion only, clouds prepared; process CPU time, robust to a loaded machine),
// points_per_kf (kept cloud), sizes in bytes.
#include <benchmark/benchmark.h>
#include <octomap/OcTree.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <memory>

#include "rgbdmap/dataset/association.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/proto/map_payload.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace {

using namespace rgbdmap;

struct Keyframes {
  std::string source;
  CameraIntrinsics camera;
  std::vector<RgbdFrame> frames;
  std::vector<SE3> T_map_cam;
  size_t raw_points = 0;  ///< valid depth pixels of all keyframes
};

Keyframes loadFr1Rpy() {
  Keyframes k;
  const auto dataset = TumDataset::open(std::string(RGBDMAP_SHARED_DATA_DIR) + "/tum_fr1_rpy_first250");
  if (!dataset || !dataset->groundTruth()) return k;
  const Trajectory& gt = *dataset->groundTruth();
  std::vector<double> frame_t, gt_t;
  for (size_t i = 0; i < dataset->size(); i += 3) frame_t.push_back(dataset->entry(i).rgb_timestamp);
  for (const auto& p : gt) gt_t.push_back(p.timestamp);
  SE3 T_world_map = SE3::Identity();
  for (const IndexPair& m : associate(frame_t, gt_t, 0.02)) {
    auto frame = dataset->load(m.a * 3);
    if (!frame) continue;
    if (k.frames.empty()) T_world_map = gt[m.b].T_world_cam;
    k.T_map_cam.push_back(T_world_map.inverse() * gt[m.b].T_world_cam);
    k.frames.push_back(std::move(*frame));
  }
  k.source = "fr1_rpy_first250 every 3rd frame";
  return k;
}

Keyframes loadSynthetic() {
  Keyframes k;
  SynthConfig sc;
  sc.frames = 84;
  auto scene = SyntheticScene::build(sc);
  for (int i = 0; i < sc.frames; ++i) {
    k.frames.push_back(scene->renderFrame(i));
    k.T_map_cam.push_back(scene->trajectory()[0].T_world_cam.inverse() *
                          scene->trajectory()[static_cast<size_t>(i)].T_world_cam);
  }
  k.camera = sc.camera;
  k.source = "synthetic loop, 84 frames";
  return k;
}

const Keyframes& keyframes() {
  static const Keyframes k = [] {
    Keyframes out = loadFr1Rpy();
    if (out.frames.empty()) out = loadSynthetic();
    for (const RgbdFrame& f : out.frames) out.raw_points += static_cast<size_t>(cv::countNonZero(f.depth));
    std::fprintf(stderr, "keyframes: %zu from %s\n", out.frames.size(), out.source.c_str());
    return out;
  }();
  return k;
}

std::vector<KeyframeCloud> makeClouds(const OccupancyMapConfig& config) {
  const Keyframes& k = keyframes();
  const KeyframeCloudMaker maker{PinholeCamera(k.camera), config};
  std::vector<KeyframeCloud> clouds;
  for (size_t i = 0; i < k.frames.size(); ++i)
    clouds.push_back(
        *maker.make(static_cast<int64_t>(i), k.frames[i].depth, k.frames[i].depth_scale, k.frames[i].color));
  return clouds;
}

OccupancyMapConfig configAt(double resolution_m) {
  OccupancyMapConfig c;
  c.resolution_m = resolution_m;
  return c;
}

void BM_MakeKeyframeCloud(benchmark::State& state) {
  const OccupancyMapConfig config = configAt(state.range(0) / 100.0);
  const Keyframes& k = keyframes();
  const KeyframeCloudMaker maker{PinholeCamera(k.camera), config};
  size_t i = 0, points = 0, n = 0;
  for (auto _ : state) {
    const RgbdFrame& f = k.frames[i++ % k.frames.size()];
    auto cloud = maker.make(0, f.depth, f.depth_scale, f.color);
    points += cloud->points_cam.size();
    ++n;
  }
  state.counters["points_per_kf"] = double(points) / n;
  state.counters["pixel_stride"] = maker.stride();
}

/// Insertion of every keyframe into one map (ms per keyframe, mean over the sequence).
void BM_InsertKeyframes(benchmark::State& state) {
  const OccupancyMapConfig config = configAt(state.range(0) / 100.0);
  const std::vector<KeyframeCloud> clouds = makeClouds(config);
  const Keyframes& k = keyframes();
  OccupancyMapStats stats;
  size_t points = 0;
  for (const auto& c : clouds) points += c.points_cam.size();
  double cpu_ms = 0.0;
  for (auto _ : state) {
    OccupancyMap map(config);
    const std::clock_t c0 = std::clock();
    for (size_t i = 0; i < clouds.size(); ++i) map.insert(clouds[i], 0, k.T_map_cam[i]);
    cpu_ms += 1000.0 * double(std::clock() - c0) / CLOCKS_PER_SEC;
    state.PauseTiming();
    stats = map.stats();
    state.ResumeTiming();
  }
  state.counters["cpu_ms_per_kf"] = cpu_ms / double(clouds.size() * state.iterations());
  state.counters["points_per_kf"] = double(points) / clouds.size();
  state.counters["leaves"] = double(stats.leaf_nodes);
  state.counters["tree_MB"] = stats.tree_memory_bytes / 1e6;
}

/// Reference: OctoMap's own insertPointCloud(discretize = true) with the same kept clouds.
void BM_InsertOctomapDiscretized(benchmark::State& state) {
  const OccupancyMapConfig config = configAt(state.range(0) / 100.0);
  const std::vector<KeyframeCloud> clouds = makeClouds(config);
  const Keyframes& k = keyframes();
  std::vector<octomap::Pointcloud> scans(clouds.size());
  for (size_t i = 0; i < clouds.size(); ++i)
    for (const auto& p : clouds[i].points_cam) {
      const Eigen::Vector3f q = k.T_map_cam[i].cast<float>() * p;
      scans[i].push_back(q.x(), q.y(), q.z());
    }
  double cpu_ms = 0.0;
  for (auto _ : state) {
    octomap::OcTree tree(config.resolution_m);
    const std::clock_t c0 = std::clock();
    for (size_t i = 0; i < clouds.size(); ++i) {
      const Vec3 o = k.T_map_cam[i].translation();
      tree.insertPointCloud(scans[i], octomap::point3d(float(o.x()), float(o.y()), float(o.z())),
                            config.max_range_m, false, true);
    }
    cpu_ms += 1000.0 * double(std::clock() - c0) / CLOCKS_PER_SEC;
  }
  state.counters["cpu_ms_per_kf"] = cpu_ms / double(clouds.size() * state.iterations());
}

/// Full rebuild of the whole map after every keyframe moved (background worker, wall time to swap).
void BM_RebuildWholeMap(benchmark::State& state) {
  const OccupancyMapConfig config = configAt(state.range(0) / 100.0);
  const std::vector<KeyframeCloud> clouds = makeClouds(config);
  const Keyframes& k = keyframes();
  OccupancyMap map(config);
  for (size_t i = 0; i < clouds.size(); ++i) map.insert(clouds[i], 0, k.T_map_cam[i]);
  int round = 0;
  for (auto _ : state) {
    std::map<int64_t, std::pair<int, SE3>> poses;
    const SE3 shift(Eigen::Translation3d(0.0, 0.0, (++round % 2) ? 0.1 : 0.0));
    for (size_t i = 0; i < clouds.size(); ++i) poses[int64_t(i)] = {0, shift * k.T_map_cam[i]};
    map.updatePoses(poses);
    map.waitIdle(600.0);
  }
  state.counters["keyframes"] = double(clouds.size());
  state.counters["last_rebuild_ms"] = map.stats().last_rebuild_ms;
  state.counters["last_rebuild_cpu_ms"] = map.stats().last_rebuild_cpu_ms;
}

void BM_Slice8mAt5cm(benchmark::State& state) {
  const OccupancyMapConfig config = configAt(state.range(0) / 100.0);
  const std::vector<KeyframeCloud> clouds = makeClouds(config);
  const Keyframes& k = keyframes();
  OccupancyMap map(config);
  for (size_t i = 0; i < clouds.size(); ++i) map.insert(clouds[i], 0, k.T_map_cam[i]);
  SliceConfig slice_config;  // 8 m x 8 m, 0.05 m, band -0.3..0.3 m, up = -y of the first camera
  size_t known = 0;
  const SE3 pose = k.T_map_cam[k.T_map_cam.size() / 2];
  map.read(0, [&](const octomap::OcTree& tree) {
    for (auto _ : state) {
      auto slice = extractSlice(tree, pose, slice_config);
      benchmark::DoNotOptimize(slice);
      known = 0;
      for (int8_t c : slice->cells) known += c != msg::OccupancySlice::kUnknown;
    }
  });
  state.counters["known_cells"] = double(known);
}

/// Every keyframe inserted into one map; *before_last: its revision before the last keyframe.
std::unique_ptr<OccupancyMap> wholeMap(const OccupancyMapConfig& config, uint64_t* before_last) {
  const std::vector<KeyframeCloud> clouds = makeClouds(config);
  const Keyframes& k = keyframes();
  auto map = std::make_unique<OccupancyMap>(config);
  for (size_t i = 0; i + 1 < clouds.size(); ++i) map->insert(clouds[i], 0, k.T_map_cam[i]);
  *before_last = map->revision(0);
  map->insert(clouds.back(), 0, k.T_map_cam.back());
  return map;
}

/// Sizes: tree memory, .bt bytes (raw and zstd), kept clouds, the raw point cloud of the same keyframes
/// (every valid depth pixel as xyz float + rgb = 15 bytes), and a partial stream of the last keyframe.
void BM_MapSizes(benchmark::State& state) {
  const OccupancyMapConfig config = configAt(state.range(0) / 100.0);
  uint64_t before_last = 0;
  const std::unique_ptr<OccupancyMap> owned = wholeMap(config, &before_last);
  OccupancyMap& map = *owned;
  MapStreamChunk full, partial;
  msg::MapUpdate update;
  for (auto _ : state) {
    full = *map.streamSince(0, 0);
    partial = *map.streamSince(0, before_last);
  }
  fillMapUpdate(full, config.resolution_m, &update);
  const OccupancyMapStats s = map.stats();
  state.counters["tree_memory_B"] = double(s.tree_memory_bytes);
  state.counters["bt_B"] = double(full.bytes.size());
  state.counters["bt_zstd_B"] = double(update.data.size());
  state.counters["kept_clouds_B"] = double(s.clouds_memory_bytes);
  state.counters["raw_cloud_B"] = double(keyframes().raw_points * 15);
  state.counters["partial_last_kf_B"] = partial.full ? -1.0 : double(partial.bytes.size());
  fillMapUpdate(partial, config.resolution_m, &update);
  state.counters["partial_zstd_B"] = double(update.data.size());
  state.counters["partial_leaves"] = double(partial.changed_leaves);
}

/// One stream of what the last keyframe changed (the map worker's call, per robot and stream period), and
/// one of the whole tree (a consumer that has nothing yet, or after a rebuild).
void BM_Stream(benchmark::State& state) {
  const OccupancyMapConfig config = configAt(state.range(0) / 100.0);
  uint64_t before_last = 0;
  const std::unique_ptr<OccupancyMap> owned = wholeMap(config, &before_last);
  OccupancyMap& map = *owned;
  const bool whole = state.range(1) != 0;
  MapStreamChunk chunk;
  for (auto _ : state) chunk = *map.streamSince(0, whole ? 0 : before_last);
  state.counters["bytes"] = double(chunk.bytes.size());
  state.counters["full"] = chunk.full ? 1.0 : 0.0;
}

}  // namespace

BENCHMARK(BM_MakeKeyframeCloud)->Arg(5)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_InsertKeyframes)->Arg(5)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_InsertOctomapDiscretized)->Arg(5)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_RebuildWholeMap)->Arg(5)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Slice8mAt5cm)->Arg(5)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MapSizes)->Arg(5)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK(BM_Stream)->Args({5, 0})->Args({5, 1})->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
