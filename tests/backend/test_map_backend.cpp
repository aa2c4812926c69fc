// MapBackend without a thread: batches of a pose graph with drift (ba off) in, results out. New nodes are
// placed by their odometry, loops the estimate satisfies need no solve, a loop it does not satisfy is solved
// (first in its neighbourhood, the whole graph when quiet), a cancelled back-end gives no result.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "backend/backend_test_util.hpp"
#include "rgbdmap/backend/map_backend.hpp"

namespace rgbdmap {
namespace {

using testing::along;
using testing::backendEdge;

MapBackendConfig graphOnly() {
  MapBackendConfig config;
  config.ba.enabled = false;
  return config;
}

/// Nodes 0..n-1 along x, 1 m apart; each after the first with an odometry edge to its predecessor.
OptimizerBatch chain(int n) {
  OptimizerBatch b;
  for (int k = 0; k < n; ++k) {
    b.nodes.push_back({k, 0, SE3::Identity(), k == 0});  // placed by their odometry
    if (k > 0) b.edges.push_back(backendEdge(k - 1, k, k - 1, along(-1.0), EdgeKind::kOdometry));
  }
  return b;
}

TEST(MapBackend, NewNodesArePlacedByTheirOdometry) {
  MapBackend backend(graphOnly());
  const std::shared_ptr<MapOptimization> r = backend.runBatch(chain(5));
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->graph_solved);
  ASSERT_EQ(r->graph.T_map_kf.size(), 5u);
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(r->graph.T_map_kf.at(k).translation().x(), k, 1e-9);
  EXPECT_EQ(r->graph.components.size(), 1u);
  EXPECT_FALSE(backend.globalDue());
}

TEST(MapBackend, ALoopTheEstimateSatisfiesNeedsNoSolve) {
  MapBackend backend(graphOnly());
  backend.runBatch(chain(5));
  OptimizerBatch loop;
  loop.edges.push_back(backendEdge(10, 4, 0, along(-4.0), EdgeKind::kLoop));
  loop.solve = true;
  const std::shared_ptr<MapOptimization> r = backend.runBatch(loop);
  ASSERT_TRUE(r);
  EXPECT_FALSE(r->graph_solved);
  EXPECT_EQ(r->solves_skipped, 1);
}

TEST(MapBackend, ALoopTheEstimateDoesNotSatisfyInASmallMapIsSolvedWhole) {
  MapBackend backend(graphOnly());
  backend.runBatch(chain(5));
  OptimizerBatch loop;
  loop.edges.push_back(backendEdge(100, 4, 0, along(-3.96), EdgeKind::kLoop));  // 4 cm of drift
  loop.solve = true;
  const std::shared_ptr<MapOptimization> r = backend.runBatch(loop);
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->graph_solved);
  EXPECT_EQ(r->local_solves, 0);  // the neighbourhood is the whole map
  EXPECT_TRUE(r->graph.disabled_edges.empty());
  const double span = r->graph.T_map_kf.at(4).translation().x() - r->graph.T_map_kf.at(0).translation().x();
  EXPECT_GT(span, 3.96);
  EXPECT_LT(span, 4.0);
  EXPECT_FALSE(backend.globalDue());
}

TEST(MapBackend, ALoopInALargeMapIsSolvedInItsNeighbourhoodAndTheWholeGraphWhenQuiet) {
  MapBackendConfig config = graphOnly();
  config.graph.local_max_nodes = 8;
  MapBackend backend(config);
  backend.runBatch(chain(30));
  OptimizerBatch loop;
  loop.edges.push_back(backendEdge(100, 29, 26, along(-2.96), EdgeKind::kLoop));
  loop.solve = true;
  const std::shared_ptr<MapOptimization> r = backend.runBatch(loop);
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->graph_solved);
  EXPECT_EQ(r->local_solves, 1);
  EXPECT_EQ(r->local_refused, 0);
  EXPECT_TRUE(backend.globalDue());  // the whole-graph solve is owed
  const std::shared_ptr<MapOptimization> idle = backend.runIdle();
  ASSERT_TRUE(idle);
  EXPECT_TRUE(idle->graph_solved);
  EXPECT_FALSE(backend.globalDue());
}

TEST(MapBackend, ACancelledBackEndGivesNoResult) {
  MapBackend backend(graphOnly());
  backend.cancel();
  EXPECT_FALSE(backend.runBatch(chain(3)));
  EXPECT_FALSE(backend.runIdle());
}

}  // namespace
}  // namespace rgbdmap
