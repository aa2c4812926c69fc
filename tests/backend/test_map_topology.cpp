// MapTopology: maps are the graph's connected components (named by their first node), anchors the fixed
// node of a map, keyframes that join another map are reported once, odometry neighbours and large cycles.
#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "backend/backend_test_util.hpp"
#include "rgbdmap/backend/map_topology.hpp"

namespace rgbdmap {
namespace {

using testing::along;
using testing::backendEdge;

/// Two chains: nodes 0-1-2 (chain 0) and 10-11 (chain 1, 11 fixed), joined by nothing.
struct TwoChains {
  PoseGraph graph;
  MapTopology topology;
  TwoChains() {
    for (int64_t id : {0, 1, 2}) add(id, 0);
    for (int64_t id : {10, 11}) add(id, 1);
    EXPECT_TRUE(graph.setFixed(11));
    edge(backendEdge(0, 1, 0, along(-1.0), EdgeKind::kOdometry));
    edge(backendEdge(1, 2, 1, along(-1.0), EdgeKind::kOdometry));
    edge(backendEdge(2, 11, 10, along(-1.0), EdgeKind::kOdometry));
  }
  void add(int64_t id, int chain) {
    ASSERT_TRUE(graph.addNode(id, chain, along(static_cast<double>(id))));
    topology.addNode(id, chain);
  }
  void edge(const PoseGraphEdge& e) {
    ASSERT_TRUE(graph.addEdge(e));
    topology.addEdge(e);
  }
};

TEST(MapTopology, MapsAreComponentsNamedByTheirFirstNodeWithTheFixedNodeAsAnchor) {
  TwoChains t;
  EXPECT_TRUE(t.topology.refresh(t.graph).empty());
  EXPECT_EQ(t.topology.mapOf(2), 0);
  EXPECT_EQ(t.topology.mapOf(11), 10);
  EXPECT_EQ(t.topology.anchorOf(0).value_or(-1), 0);
  EXPECT_EQ(t.topology.anchorOf(10).value_or(-1), 11);
  EXPECT_FALSE(t.topology.anchorOf(1).has_value());
  EXPECT_EQ(t.topology.keyframesIn(0), 3u);
  EXPECT_EQ(t.topology.keyframesIn(10), 2u);
  EXPECT_FALSE(t.topology.contains(5));
}

TEST(MapTopology, KeyframesThatJoinAnotherMapAreReportedOnce) {
  TwoChains t;
  t.topology.refresh(t.graph);
  t.edge(backendEdge(3, 10, 2, along(-8.0), EdgeKind::kInterRobot));
  const std::vector<std::pair<int64_t, int>> moved = t.topology.refresh(t.graph);
  EXPECT_EQ(moved, (std::vector<std::pair<int64_t, int>>{{10, 0}, {11, 0}}));
  EXPECT_EQ(t.topology.keyframesIn(0), 5u);
  EXPECT_EQ(t.topology.keyframesIn(10), 0u);
  EXPECT_EQ(t.topology.anchorOf(0).value_or(-1), 11);  // the fixed node holds the joined map's gauge
  EXPECT_TRUE(t.topology.refresh(t.graph).empty());
}

TEST(MapTopology, OdometryNeighboursAndLargeCycles) {
  TwoChains t;
  t.topology.refresh(t.graph);
  t.edge(backendEdge(3, 2, 0, along(-2.0), EdgeKind::kLoop));
  EXPECT_EQ(t.topology.odometryNeighbours(t.graph, 1), (std::vector<int64_t>{0, 2}));
  EXPECT_EQ(t.topology.odometryNeighbours(t.graph, 2), (std::vector<int64_t>{1}));  // not the loop
  EXPECT_EQ(t.topology.edgesOf(2), (std::vector<int64_t>{1, 3}));
  EXPECT_TRUE(t.topology.edgesOf(7).empty());
  const PoseGraphEdge loop = *t.graph.edge(3);
  EXPECT_TRUE(t.topology.isLargeCycle(loop, 1));               // 2 keyframes apart
  EXPECT_FALSE(t.topology.isLargeCycle(loop, 30));             // within the span
  EXPECT_FALSE(t.topology.isLargeCycle(*t.graph.edge(0), 0));  // odometry never
  EXPECT_TRUE(t.topology.isLargeCycle(backendEdge(4, 2, 10, along(8.0), EdgeKind::kInterRobot), 30));
}

}  // namespace
}  // namespace rgbdmap
