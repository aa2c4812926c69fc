// The bridge's pure parts: which robots share a map, the REP-105 transforms of a robot, the PointCloud2
// bytes of voxels.
#include <algorithm>
#include <cstdint>
#include <cstring>

#include "rgbdmap/ros2_bridge/bridge.hpp"

namespace rgbdmap::ros2 {

std::vector<std::vector<std::string>> mapGroups(const std::vector<std::string>& robots,
                                                const std::vector<std::vector<msg::MapLoopEdge>>& loops) {
  std::vector<size_t> parent(robots.size());
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto root = [&](size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto index = [&](const std::string& id) {
    return static_cast<size_t>(std::find(robots.begin(), robots.end(), id) - robots.begin());
  };
  for (size_t i = 0; i < robots.size() && i < loops.size(); ++i)
    for (const msg::MapLoopEdge& e : loops[i])
      for (const std::string& other : {e.robot_from, e.robot_to}) {
        const size_t j = index(other);
        if (j < robots.size()) parent[root(j)] = root(i);  // the edge is in i's map: so is `other`
      }
  std::vector<std::vector<std::string>> groups;
  std::vector<size_t> group_of_root(robots.size(), SIZE_MAX);
  for (size_t i = 0; i < robots.size(); ++i) {
    size_t& g = group_of_root[root(i)];
    if (g == SIZE_MAX) {
      g = groups.size();
      groups.emplace_back();
    }
    groups[g].push_back(robots[i]);
  }
  std::stable_sort(groups.begin(), groups.end(),
                   [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return groups;
}

OdomTransforms odomTransforms(const SE3& T_map_odom, const SE3& T_map_cam, const SE3& T_base_camera) {
  OdomTransforms t;
  t.T_map_odom = T_map_odom * T_base_camera.inverse();
  t.T_odom_base = t.T_map_odom.inverse() * baseOf(T_map_cam, T_base_camera);
  return t;
}

std::vector<uint8_t> pointCloudData(const std::vector<viewer::Voxel>& voxels) {
  float low = 0, high = 0;
  for (size_t i = 0; i < voxels.size(); ++i) {
    low = i == 0 ? voxels[i].z : std::min(low, voxels[i].z);
    high = i == 0 ? voxels[i].z : std::max(high, voxels[i].z);
  }
  std::vector<uint8_t> data(voxels.size() * 16);
  for (size_t i = 0; i < voxels.size(); ++i) {
    uint8_t* p = data.data() + 16 * i;
    std::memcpy(p, &voxels[i].x, 4);
    std::memcpy(p + 4, &voxels[i].y, 4);
    std::memcpy(p + 8, &voxels[i].z, 4);
    uint8_t rgb[3];
    viewer::heightColour(voxels[i].z, low, high, rgb);
    const uint32_t packed = (uint32_t{rgb[0]} << 16) | (uint32_t{rgb[1]} << 8) | rgb[2];
    std::memcpy(p + 12, &packed, 4);  // little-endian hosts only (checked in CMake, as for the rest)
  }
  return data;
}

}  // namespace rgbdmap::ros2
