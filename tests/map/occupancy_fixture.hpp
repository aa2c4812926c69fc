#pragma once
// Synthetic keyframes (exact poses, Kinect-like depth noise) for the occupancy map tests.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "rgbdmap/map/occupancy_map.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap::testing {

struct SynthKeyframes {
  std::shared_ptr<SyntheticScene> scene;
  std::vector<KeyframeCloud> clouds;
  std::vector<SE3> T_world_cam;
};

/// `count` frames spread over the whole path of `scene_name` ("loop" or "sweep").
inline SynthKeyframes renderSynthKeyframes(const std::string& scene_name, int count,
                                           const OccupancyMapConfig& config) {
  SynthConfig sc;
  sc.scene = scene_name;
  sc.frames = count;
  sc.seed = 5;
  // Half the sensor's 640x480 (same field of view): rendering is most of these tests' time, and at 0.05 m
  // the automatic pixel stride reads every pixel of it, so the map is nearly the same.
  sc.camera = CameraIntrinsics{262.5, 262.5, 159.5, 119.5, 320, 240, {0.0, 0.0, 0.0, 0.0, 0.0}, 5000.0, 0.0};
  auto scene = SyntheticScene::build(sc);
  EXPECT_TRUE(scene.ok()) << scene.error();
  SynthKeyframes out;
  out.scene = std::make_shared<SyntheticScene>(std::move(*scene));
  const KeyframeCloudMaker maker(PinholeCamera(sc.camera), config);
  for (int i = 0; i < count; ++i) {
    const RgbdFrame frame = out.scene->renderFrame(i);
    auto cloud = maker.make(i, frame.depth, frame.depth_scale, frame.color);
    EXPECT_TRUE(cloud.ok()) << cloud.error();
    out.clouds.push_back(std::move(*cloud));
    out.T_world_cam.push_back(out.scene->trajectory()[static_cast<size_t>(i)].T_world_cam);
  }
  return out;
}

/// renderSynthKeyframes at the default config, rendered once per process (rendering dominates test time).
inline const SynthKeyframes& makeSynthKeyframes(const std::string& scene_name, int count) {
  static std::map<std::pair<std::string, int>, SynthKeyframes> cache;
  auto it = cache.find({scene_name, count});
  if (it == cache.end())
    it = cache
             .emplace(std::make_pair(scene_name, count),
                      renderSynthKeyframes(scene_name, count, OccupancyMapConfig{}))
             .first;
  return it->second;
}

struct LeafCounts {
  size_t leaves = 0, occupied = 0;
  bool operator==(const LeafCounts& o) const { return leaves == o.leaves && occupied == o.occupied; }
};

inline LeafCounts countLeaves(const octomap::OcTree& tree) {
  LeafCounts c;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    ++c.leaves;
    if (tree.isNodeOccupied(*it)) ++c.occupied;
  }
  return c;
}

inline LeafCounts countLeaves(const OccupancyMap& map, int map_id) {
  LeafCounts c;
  map.read(map_id, [&](const octomap::OcTree& tree) { c = countLeaves(tree); });
  return c;
}

/// Distance to the first occupied cell along a ray (ignoring unknown cells), or -1.
inline double octreeHitDistance(const octomap::OcTree& tree, const Vec3& origin, const Vec3& direction) {
  octomap::point3d end;
  const octomap::point3d o(float(origin.x()), float(origin.y()), float(origin.z()));
  if (!tree.castRay(o, octomap::point3d(float(direction.x()), float(direction.y()), float(direction.z())),
                    end, true, 10.0))
    return -1.0;
  return (end - o).norm();
}

}  // namespace rgbdmap::testing
