// Timings of the map exports on the synthetic room (30 keyframes of the loop at ground-truth poses, 640x480):
// voxel accumulation of a keyframe's points, PLY writing, the top-down picture of the room's octree, a slice
// written for map_server. Prints numbers (and leaves the files in $TMPDIR/rgbdmap_bench_export/ to look
// at); asserts nothing.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/export/map_picture.hpp"
#include "rgbdmap/export/point_cloud_export.hpp"
#include "rgbdmap/export/slice_export.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap {
namespace {

struct Keyframe {
  std::vector<Eigen::Vector3f> points_cam;
  std::vector<std::array<uint8_t, 3>> rgb;
  SE3 T_map_cam;
};

struct RoomData {
  std::vector<Keyframe> keyframes;
  std::unique_ptr<octomap::OcTree> tree;
  std::vector<SE3> trajectory;
};

Keyframe backProject(const RgbdFrame& f, const PinholeCamera& camera, const SE3& T_map_cam, int stride) {
  Keyframe k;
  k.T_map_cam = T_map_cam;
  for (int v = 0; v < f.depth.rows; v += stride)
    for (int u = 0; u < f.depth.cols; u += stride) {
      const double z = f.depthMetres(u, v);
      if (z <= 0.0) continue;
      k.points_cam.push_back(camera.backProject(Eigen::Vector2d(u, v), z).cast<float>());
      const cv::Vec3b c = f.color.at<cv::Vec3b>(v, u);
      k.rgb.push_back({c[2], c[1], c[0]});
    }
  return k;
}

/// Built once: keyframes every 10th frame of the 300-frame loop, map frame = the first camera's.
const RoomData& room() {
  static const RoomData data = [] {
    RoomData d;
    SynthConfig cfg;
    auto scene = SyntheticScene::build(cfg);
    if (!scene) std::abort();
    const PinholeCamera camera(cfg.camera);
    const SE3 T_map_world = scene->trajectory().front().T_world_cam.inverse();
    d.tree = std::make_unique<octomap::OcTree>(0.05);
    for (int i = 0; i < cfg.frames; i += 10) {
      const SE3 T_map_cam = T_map_world * scene->trajectory()[i].T_world_cam;
      const RgbdFrame f = scene->renderFrame(i);
      d.keyframes.push_back(backProject(f, camera, T_map_cam, 1));
      const Keyframe sparse = backProject(f, camera, T_map_cam, 4);
      octomap::Pointcloud cloud;
      for (const auto& p : sparse.points_cam) {
        const Vec3 q = T_map_cam * p.cast<double>();
        cloud.push_back(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
      }
      const Vec3 o = T_map_cam.translation();
      d.tree->insertPointCloud(cloud, octomap::point3d(o.x(), o.y(), o.z()), 4.0);
    }
    for (const auto& stamped : scene->trajectory()) d.trajectory.push_back(T_map_world * stamped.T_world_cam);
    return d;
  }();
  return data;
}

std::string outPath(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "rgbdmap_bench_export";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

void BM_VoxelCloudAddKeyframe(benchmark::State& state) {
  const RoomData& data = room();
  const double voxel_m = 0.01 * static_cast<double>(state.range(0));
  size_t i = 0, points = 0;
  VoxelCloud cloud(voxel_m);
  for (auto _ : state) {
    const Keyframe& k = data.keyframes[i++ % data.keyframes.size()];
    benchmark::DoNotOptimize(cloud.add(k.points_cam, k.rgb, k.T_map_cam));
    points += k.points_cam.size();
  }
  VoxelCloud all(voxel_m);
  size_t all_points = 0;
  for (const Keyframe& k : data.keyframes)
    (void)all.add(k.points_cam, k.rgb, k.T_map_cam), all_points += k.points_cam.size();
  state.counters["points_per_keyframe"] = static_cast<double>(points) / state.iterations();
  state.counters["voxels_30_keyframes"] = static_cast<double>(all.size());
  state.counters["input_points_30_keyframes"] = static_cast<double>(all_points);
  state.counters["ply_MB"] = all.size() * 15.0 / 1e6;
  (void)writePly(outPath("map_" + std::to_string(state.range(0)) + "cm.ply"), all.points());
}
BENCHMARK(BM_VoxelCloudAddKeyframe)->Arg(1)->Arg(2)->Arg(5)->Unit(benchmark::kMillisecond);

void BM_WritePly(benchmark::State& state) {
  const RoomData& data = room();
  VoxelCloud cloud(0.01);
  for (const Keyframe& k : data.keyframes) (void)cloud.add(k.points_cam, k.rgb, k.T_map_cam);
  const auto points = cloud.points();
  for (auto _ : state) benchmark::DoNotOptimize(writePly(outPath("bench.ply"), points));
  state.counters["points"] = static_cast<double>(points.size());
  state.counters["MB"] = points.size() * 15.0 / 1e6;
}
BENCHMARK(BM_WritePly)->Unit(benchmark::kMillisecond);

void BM_RenderMapPicture(benchmark::State& state) {
  const RoomData& data = room();
  MapPictureOptions options;
  options.max_side_px = static_cast<int>(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(renderMapPicture(*data.tree, {{"robot0", data.trajectory}}, options));
  state.counters["leaves"] = static_cast<double>(data.tree->getNumLeafNodes());
  (void)writeMapPicture(*data.tree, {{"robot0", data.trajectory}}, outPath("map.png"), options);
}
BENCHMARK(BM_RenderMapPicture)->Arg(1200)->Unit(benchmark::kMillisecond);

void BM_WriteSlice(benchmark::State& state) {
  msg::OccupancySlice s;
  s.robot_id = "robot0";
  s.width = s.height = static_cast<int>(state.range(0));
  s.cells.assign(static_cast<size_t>(s.width) * s.height, msg::OccupancySlice::kFree);
  for (size_t i = 0; i < s.cells.size(); i += 7) s.cells[i] = msg::OccupancySlice::kOccupied;
  for (auto _ : state) benchmark::DoNotOptimize(writeSlice(s, outPath("slice.pgm"), outPath("slice.yaml")));
}
BENCHMARK(BM_WriteSlice)->Arg(200)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace rgbdmap

BENCHMARK_MAIN();
