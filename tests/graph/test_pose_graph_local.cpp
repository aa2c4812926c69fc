// PoseGraph::optimizeLocal: a new loop's neighbourhood solved with the nodes around it fixed, kept only when
// every edge there fits; long cycles and false loops are left to the whole-graph solve.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_synth.hpp"

namespace rgbdmap {
namespace {

PoseGraphEdge edgeBetween(SynthGraph* s, size_t from, size_t to, const SE3& noise, EdgeKind kind) {
  PoseGraphEdge e;
  e.id = s->next_edge_id++;
  e.from = s->node_ids[from];
  e.to = s->node_ids[to];
  e.T_from_to = se3::normalized(noise * s->T_map_kf_true[from].inverse() * s->T_map_kf_true[to]);
  e.information = diagonalInformation(0.01, 0.004);
  e.kind = kind;
  return e;
}

SE3 smallNoise(std::mt19937* rng, double sigma_t, double sigma_r) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 d;
  for (int i = 0; i < 3; ++i) d[i] = sigma_t * n(*rng);
  for (int i = 3; i < 6; ++i) d[i] = sigma_r * n(*rng);
  return se3::exp(d);
}

/// The solver bounded by iterations only: the tests must not depend on the machine's speed (under the
/// sanitizers a solve of the room takes longer than the default 2 s).
PoseGraphConfig untimed() {
  PoseGraphConfig c;
  c.max_solver_time_s = 600.0;
  return c;
}

/// A room revisited 12 times (46 keyframes a lap, each loop keyframe tied to 6 earlier laps), solved.
SynthGraph solvedRoom() {
  SynthGraph s = makeSynthGraph(revisitedRoom(46 * 12, 6, 3));
  EXPECT_TRUE(s.graph.setFixed(s.node_ids.front()).ok());
  const auto report = s.graph.optimize(untimed());
  EXPECT_TRUE(report.ok() && !report->out_of_time);
  return s;
}

/// Appends a keyframe at `T_true`: odometry from the last one, its pose chained from the last one's
/// estimate and then off by `pose_error` (drift the loops correct), and `loops` loops to the same place in
/// earlier laps. Returns the loops' ids.
std::vector<int64_t> appendKeyframe(SynthGraph* s, const SE3& T_true, const SE3& pose_error, int loops,
                                    std::mt19937* rng) {
  const size_t last = s->node_ids.size() - 1;
  s->node_ids.push_back(s->node_ids.back() + 1);
  s->T_map_kf_true.push_back(T_true);
  const size_t k = last + 1;
  const PoseGraphEdge odo = edgeBetween(s, last, k, smallNoise(rng, 0.01, 0.004), EdgeKind::kOdometry);
  EXPECT_TRUE(
      s->graph.addNode(s->node_ids[k], 0, pose_error * *s->graph.pose(s->node_ids[last]) * odo.T_from_to)
          .ok());
  EXPECT_TRUE(s->graph.addEdge(odo).ok());
  std::vector<int64_t> ids;
  for (int l = 1; l <= loops; ++l) {
    ids.push_back(s->next_edge_id);
    EXPECT_TRUE(s->graph
                    .addEdge(edgeBetween(s, k - 46 * static_cast<size_t>(l), k, smallNoise(rng, 0.01, 0.004),
                                         EdgeKind::kLoop))
                    .ok());
  }
  return ids;
}

// A new keyframe 8 cm off, with three loops to earlier passes: the local solve takes it
// (and its neighbourhood) onto the loops, moves no node outside the region and is as close to the truth as
// the whole-graph solve.
TEST(PoseGraphLocal, ANewKeyframesLoopsAreSolvedInItsNeighbourhoodOnly) {
  SynthGraph room = solvedRoom();
  std::mt19937 rng(5);
  const size_t n = room.node_ids.size();
  const SE3 T_true = room.T_map_kf_true[n - 46];  // the next place: the laps are periodic
  SE3 error = SE3::Identity();
  error.translation() = Vec3(0.08, 0.0, 0.0);
  const std::vector<int64_t> loops = appendKeyframe(&room, T_true, error, 3, &rng);
  const size_t k = n;
  EXPECT_GT((room.graph.pose(room.node_ids[k])->translation() - T_true.translation()).norm(), 0.05);
  PoseGraph global = room.graph;
  const std::map<int64_t, SE3> before = room.graph.poses();

  PoseGraphConfig config = untimed();
  config.local_max_nodes = 60;
  const LocalOptimizeReport r = room.graph.optimizeLocal(loops, config);
  ASSERT_TRUE(r.accepted) << "worst chi2 " << r.worst_chi2 << ", " << r.iterations << " iterations";
  EXPECT_FALSE(r.whole_component);
  EXPECT_EQ(r.region_nodes, 60);
  EXPECT_GT(r.boundary_nodes, 0);
  EXPECT_LE(r.worst_chi2, config.outlier_chi2);
  EXPECT_LE(r.worst_strain_chi2, config.local_strain_chi2);
  EXPECT_EQ(r.moved_nodes.size(), 60u);
  const std::set<int64_t> moved(r.moved_nodes.begin(), r.moved_nodes.end());
  EXPECT_TRUE(moved.count(room.node_ids[k]));
  for (const auto& [id, T] : room.graph.poses())
    if (!moved.count(id)) {
      EXPECT_TRUE(T.isApprox(before.at(id), 0.0)) << "node " << id << " moved";
    }
  const double local_error = (room.graph.pose(room.node_ids[k])->translation() - T_true.translation()).norm();
  ASSERT_TRUE(global.optimize(untimed()).ok());
  const double global_error = (global.pose(room.node_ids[k])->translation() - T_true.translation()).norm();
  EXPECT_LT(local_error, 0.02);
  EXPECT_LT(local_error, global_error + 0.005) << "global " << global_error;
  EXPECT_NEAR(translationRmse(room.graph, room), translationRmse(global, room), 0.002);
}

// A loop that closes a long cycle (one lap of drift onto its start): the fixed nodes around the region keep
// it from absorbing the drift (the loop, under its robust loss, still does not fit), so the local answer is
// refused and the graph stays as it was.
TEST(PoseGraphLocal, ALoopClosingALongCycleIsRefused) {
  SynthGraphConfig c;
  c.keyframes = 200;
  c.keyframes_per_lap = 200;
  c.radius_m = 8.0;
  c.odom_sigma_t = 0.02;
  c.seed = 2;
  SynthGraph s = makeSynthGraph(c);
  ASSERT_TRUE(s.graph.setFixed(s.node_ids.front()).ok());
  std::mt19937 rng(1);
  ASSERT_TRUE(s.graph.addEdge(edgeBetween(&s, 0, 199, smallNoise(&rng, 0.01, 0.004), EdgeKind::kLoop)).ok());
  const int64_t loop = s.next_edge_id - 1;
  ASSERT_GT(*s.graph.edgeChi2(loop), 100.0) << "the cycle's drift";
  const std::map<int64_t, SE3> before = s.graph.poses();
  PoseGraphConfig config = untimed();
  config.local_max_nodes = 30;
  const LocalOptimizeReport r = s.graph.optimizeLocal({loop}, config);
  std::printf(
      "[ measured ] one lap of drift closed in 30 nodes: loop chi2 %.1f before, %.1f after, strain chi2 "
      "%.1f\n",
      *s.graph.edgeChi2(loop), r.worst_chi2, r.worst_strain_chi2);
  EXPECT_FALSE(r.accepted);
  EXPECT_GT(r.worst_chi2, config.outlier_chi2) << "the loop cannot be made to fit by a region of 30 nodes";
  EXPECT_TRUE(r.moved_nodes.empty());
  for (const auto& [id, T] : s.graph.poses()) EXPECT_TRUE(T.isApprox(before.at(id), 0.0));
  // The whole-graph solve closes it and keeps the loop.
  const auto global = s.graph.optimize(untimed());
  ASSERT_TRUE(global.ok());
  EXPECT_EQ(global->loops_rejected, 0);
  EXPECT_LT(*s.graph.edgeChi2(loop), config.outlier_chi2);
}

// A false loop (1 m off) in a solved room: refused locally (no loop is disabled there); the whole-graph
// solve disables it.
TEST(PoseGraphLocal, AFalseLoopIsRefusedAndLeftToTheWholeGraphSolve) {
  SynthGraph room = solvedRoom();
  SE3 wrong = SE3::Identity();
  wrong.translation() = Vec3(1.0, 0.0, 0.0);
  PoseGraphEdge e = edgeBetween(&room, 100, 400, wrong, EdgeKind::kLoop);
  ASSERT_TRUE(room.graph.addEdge(e).ok());
  const std::map<int64_t, SE3> before = room.graph.poses();
  const std::vector<int64_t> disabled = room.graph.disabledEdges();  // true loops past the 99.9% quantile
  PoseGraphConfig config = untimed();
  config.local_max_nodes = 100;
  const LocalOptimizeReport r = room.graph.optimizeLocal({e.id}, config);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(room.graph.disabledEdges(), disabled);
  for (const auto& [id, T] : room.graph.poses()) EXPECT_TRUE(T.isApprox(before.at(id), 0.0));
  const auto global = room.graph.optimize(untimed());
  ASSERT_TRUE(global.ok());
  const std::vector<int64_t>& now = room.graph.disabledEdges();
  EXPECT_TRUE(std::binary_search(now.begin(), now.end(), e.id));
  EXPECT_LE(now.size(), disabled.size() + 1);
}

// A region that reaches its whole component solves nothing: that is the whole-graph solve's work.
TEST(PoseGraphLocal, ARegionCoveringItsComponentDefersToTheWholeGraphSolve) {
  SynthGraphConfig c;
  c.keyframes = 40;
  c.keyframes_per_lap = 20;
  SynthGraph s = makeSynthGraph(c);
  const std::map<int64_t, SE3> before = s.graph.poses();
  const LocalOptimizeReport r = s.graph.optimizeLocal({s.loop_edge_ids.front()}, untimed());
  EXPECT_TRUE(r.whole_component);
  EXPECT_FALSE(r.accepted);
  EXPECT_EQ(r.region_nodes, 40);
  for (const auto& [id, T] : s.graph.poses()) EXPECT_TRUE(T.isApprox(before.at(id), 0.0));
  EXPECT_FALSE(s.graph.optimizeLocal({12345678}, untimed()).accepted) << "unknown seeds";
}

}  // namespace
}  // namespace rgbdmap
