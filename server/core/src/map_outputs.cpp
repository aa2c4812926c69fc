// MapWorker::writeOutputs: the map's files for people and tools (MapServer::writeMapOutputs).
#include <algorithm>
#include <chrono>
#include <filesystem>

#include "rgbdmap/export/map_picture.hpp"
#include "rgbdmap/export/point_cloud_export.hpp"
#include "rgbdmap/export/slice_export.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/map/occupancy_slice.hpp"
#include "rgbdmap/workers/map_worker.hpp"

namespace rgbdmap {
namespace {

constexpr double kPlyVoxelM = 0.02;

/// The map with the most kept keyframes among those that have a tree (the merged map when robots met).
int mainMapId(const std::vector<OccupancyMap::KeptCloud>& clouds, const std::vector<int>& map_ids) {
  std::map<int, size_t> count;
  for (const auto& c : clouds) ++count[c.map_id];
  int best = map_ids.front();
  for (int id : map_ids)
    if (count[id] > count[best]) best = id;
  return best;
}

Status writeCloud(const std::vector<OccupancyMap::KeptCloud>& clouds, const std::string& path) {
  VoxelCloud voxels(kPlyVoxelM);
  for (const auto& c : clouds) {
    std::vector<std::array<uint8_t, 3>> grey;
    if (c.cloud->colors_rgb.empty()) grey.assign(c.cloud->points_cam.size(), {128, 128, 128});
    const auto& rgb = c.cloud->colors_rgb.empty() ? grey : c.cloud->colors_rgb;
    if (const Status s = voxels.add(c.cloud->points_cam, rgb, c.T_map_cam); !s)
      return Status::failure("map.ply: keyframe " + std::to_string(c.cloud->keyframe_id) + ": " + s.error());
  }
  return writePly(path, voxels.points());
}

/// The median height along `up` of the cameras of map `map_id`'s keyframes (0 without any): the global 2-D
/// map is cut at the robots' camera height, as their slices are.
double cameraHeight(const std::vector<ServerKeyframe>& keyframes, int map_id, const Vec3& up) {
  std::vector<double> heights;
  for (const ServerKeyframe& k : keyframes)
    if (k.map_id == map_id) heights.push_back(k.T_map_kf.translation().dot(up));
  if (heights.empty()) return 0.0;
  std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
  return heights[heights.size() / 2];
}

/// map_<id>.pgm + map_<id>.yaml: the map's global 2-D occupancy map (ROS map_server / nav2, no yaw).
Status writeMapGrid(const octomap::OcTree& tree, int map_id, const std::vector<ServerKeyframe>& keyframes,
                    const SliceConfig& config, const std::filesystem::path& dir) {
  const double height = cameraHeight(keyframes, map_id, config.up_in_map.normalized());
  Result<msg::OccupancySlice> grid = extractMapGrid(tree, height, config);
  if (!grid) return Status::failure("map_" + std::to_string(map_id) + ".pgm: " + grid.error());
  grid->header.utime = std::chrono::duration_cast<std::chrono::microseconds>(
                           std::chrono::system_clock::now().time_since_epoch())
                           .count();
  const std::string base = (dir / ("map_" + std::to_string(map_id))).string();
  return writeSlice(*grid, base + ".pgm", base + ".yaml");
}

}  // namespace

Status MapWorker::writeOutputs(const std::string& out_dir,
                               const std::vector<ServerKeyframe>& keyframes) const {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return Status::failure("cannot create " + out_dir + ": " + ec.message());
  const std::vector<OccupancyMap::KeptCloud> clouds = occupancy_.keptClouds();
  const std::vector<int> map_ids = occupancy_.mapIds();
  if (map_ids.empty() || clouds.empty()) return Status::failure("the occupancy map is empty");
  const int main_id = mainMapId(clouds, map_ids);
  const fs::path dir(out_dir);

  std::vector<NamedTrajectory> trajectories;  // keyframes of the main map, per robot, in ingestion order
  for (const ServerKeyframe& k : keyframes) {
    if (k.map_id != main_id) continue;
    auto it = std::find_if(trajectories.begin(), trajectories.end(),
                           [&](const NamedTrajectory& t) { return t.first == k.robot_id; });
    if (it == trajectories.end()) it = trajectories.insert(trajectories.end(), {k.robot_id, {}});
    it->second.push_back(k.T_map_kf);
  }
  Status status = Status::success();
  for (int id : map_ids) {
    occupancy_.read(id, [&](const octomap::OcTree& tree) {
      if (!status) return;
      status = writeMapGrid(tree, id, keyframes, config_.slice, dir);
      if (!status) return;
      if (id == main_id) {
        status = writeMapFiles(tree, (dir / "map.bt").string(), (dir / "map.ot").string());
        if (status) status = writeMapPicture(tree, trajectories, (dir / "map.png").string());
      } else {
        status = writeMapFiles(tree, (dir / ("map_" + std::to_string(id) + ".bt")).string(), "");
      }
    });
    if (!status) return status;
  }
  std::vector<OccupancyMap::KeptCloud> main_clouds;
  for (const auto& c : clouds)
    if (c.map_id == main_id) main_clouds.push_back(c);
  if (const Status s = writeCloud(main_clouds, (dir / "map.ply").string()); !s) return s;
  std::map<std::string, msg::OccupancySlice> slices;
  {
    std::lock_guard<std::mutex> lock(state_mutex_);
    slices = last_slices_;
  }
  for (const auto& [robot, slice] : slices) {
    const std::string base = (dir / ("slice_" + robot)).string();
    if (const Status s = writeSlice(slice, base + ".pgm", base + ".yaml"); !s) return s;
  }
  return Status::success();
}

}  // namespace rgbdmap
