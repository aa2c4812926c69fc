#pragma once
// The occupancy map tests' configuration, inserting synthetic keyframes, and comparing two trees leaf by
// leaf.
#include <algorithm>
#include <cstddef>

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include "occupancy_fixture.hpp"

namespace rgbdmap::testing {

inline OccupancyMapConfig testConfig() {
  OccupancyMapConfig c;
  c.resolution_m = 0.05;
  return c;
}

inline void insertAll(OccupancyMap* map, const testing::SynthKeyframes& kf, int map_id, size_t begin = 0,
                      size_t end = ~size_t{0}, const SE3& T_map_world = SE3::Identity()) {
  for (size_t i = begin; i < std::min(end, kf.clouds.size()); ++i)
    ASSERT_TRUE(map->insert(kf.clouds[i], map_id, T_map_world * kf.T_world_cam[i]).ok());
}

/// Every leaf of a and b, expanded to the finest level, with exactly the same log-odds; returns the leaves.
inline size_t expectSameLeaves(const octomap::OcTree& a, const octomap::OcTree& b) {
  size_t n = 0, differ = 0, missing = 0;
  const auto walk = [&](const octomap::OcTree& x, const octomap::OcTree& y, bool count) {
    for (auto it = x.begin_leafs(), end = x.end_leafs(); it != end; ++it) {
      const unsigned side = 1u << (16 - it.getDepth());
      const octomap::OcTreeKey base = it.getIndexKey();
      for (unsigned i = 0; i < side; ++i)
        for (unsigned j = 0; j < side; ++j)
          for (unsigned k = 0; k < side; ++k) {
            const octomap::OcTreeKey key(base[0] + i, base[1] + j, base[2] + k);
            const octomap::OcTreeNode* other = y.search(key);
            if (count) ++n;
            if (!other)
              ++missing;
            else if (other->getLogOdds() != it->getLogOdds())
              ++differ;
          }
    }
  };
  walk(a, b, true);
  walk(b, a, false);
  EXPECT_EQ(missing, 0u) << "leaves known in one tree only";
  EXPECT_EQ(differ, 0u) << "leaves with different log-odds";
  return n;
}
}  // namespace rgbdmap::testing
