// Timings of the map exports on synthetic data: voxel accumulation of keyframe points, PLY writing, the
// top-down picture of a room-sized octree. Prints numbers; asserts nothing.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <random>

#include "rgbdmap/export/map_picture.hpp"
#include "rgbdmap/export/point_cloud_export.hpp"

namespace rgbdmap {
namespace {

/// A 640x480 keyframe's worth of points on a wall 2 m ahead with a box in front, camera frame.
void keyframePoints(std::vector<Eigen::Vector3f>* points, std::vector<std::array<uint8_t, 3>>* rgb) {
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.002f);
  for (int v = 0; v < 480; ++v)
    for (int u = 0; u < 640; ++u) {
      const float z = (u > 200 && u < 400 && v > 250) ? 1.2f : 2.0f;
      points->emplace_back((u - 319.5f) / 525.0f * z, (v - 239.5f) / 525.0f * z, z + noise(rng));
      rgb->push_back({static_cast<uint8_t>(u), static_cast<uint8_t>(v), 128});
    }
}

void BM_VoxelCloudAddKeyframe(benchmark::State& state) {
  std::vector<Eigen::Vector3f> points;
  std::vector<std::array<uint8_t, 3>> rgb;
  keyframePoints(&points, &rgb);
  VoxelCloud cloud(0.01 * static_cast<double>(state.range(0)));
  int k = 0;
  for (auto _ : state) {
    SE3 T = SE3::Identity();
    T.translation() = Vec3(0.001 * (k % 100), 0, 0);
    ++k;
    benchmark::DoNotOptimize(cloud.add(points, rgb, T));
  }
  state.counters["voxels"] = static_cast<double>(cloud.size());
  state.counters["points_per_s"] =
      benchmark::Counter(static_cast<double>(points.size()), benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_VoxelCloudAddKeyframe)->Arg(1)->Arg(2)->Arg(5)->Unit(benchmark::kMillisecond);

void BM_WritePly(benchmark::State& state) {
  std::vector<ColoredPoint> points(static_cast<size_t>(state.range(0)));
  for (size_t i = 0; i < points.size(); ++i) points[i].p = Eigen::Vector3f(i * 1e-3f, 0.5f, 2.0f);
  const std::string path = (std::filesystem::temp_directory_path() / "bench_map_export.ply").string();
  for (auto _ : state) benchmark::DoNotOptimize(writePly(path, points));
  std::remove(path.c_str());
  state.counters["MB"] = points.size() * 15.0 / 1e6;
}
BENCHMARK(BM_WritePly)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond);

/// A 6 x 5 m room (floor, walls, ceiling) at 5 cm, free space inside, map frame y down.
octomap::OcTree roomTree() {
  octomap::OcTree tree(0.05);
  for (double x = -3.0; x <= 3.0; x += 0.05)
    for (double z = -2.5; z <= 2.5; z += 0.05) {
      tree.updateNode(octomap::point3d(x, 1.3f, z), true);   // floor
      tree.updateNode(octomap::point3d(x, -1.5f, z), true);  // ceiling
      tree.updateNode(octomap::point3d(x, 0.0f, z), false);  // free at camera height
      const bool wall = std::abs(x) > 2.95 || std::abs(z) > 2.45;
      if (wall)
        for (double y = -1.5; y <= 1.3; y += 0.05) tree.updateNode(octomap::point3d(x, y, z), true);
    }
  return tree;
}

void BM_RenderMapPicture(benchmark::State& state) {
  const octomap::OcTree tree = roomTree();
  std::vector<SE3> poses;
  for (int i = 0; i < 300; ++i) {
    SE3 T = SE3::Identity();
    T.translation() = Vec3(std::cos(i * 0.02), 0.0, std::sin(i * 0.02));
    poses.push_back(T);
  }
  MapPictureOptions options;
  options.max_side_px = static_cast<int>(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(renderMapPicture(tree, {{"robot0", poses}}, options));
  state.counters["leaves"] = static_cast<double>(tree.getNumLeafNodes());
}
BENCHMARK(BM_RenderMapPicture)->Arg(1200)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace rgbdmap

BENCHMARK_MAIN();
