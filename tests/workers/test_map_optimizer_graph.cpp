// The map optimiser's pose-graph solves, fed keyframe by keyframe: whole-graph solves only for loops the
// estimate does not satisfy, neighbourhood solves in a revisited room, a new chain meeting a large map.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "rgbdmap/graph/pose_graph_synth.hpp"
#include "test_tier.hpp"
#include "workers/map_optimizer_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::backendEdge;
using testing::Collector;

struct GraphRun {
  double rms_m = 0.0;
  int solves = 0, skipped = 0, local = 0, local_refused = 0;
  int local_at_end = 0;  ///< local solves when the last keyframe's result came
  bool settled = false;  ///< a whole-graph solve came by itself once the optimiser was quiet
  std::vector<int64_t> disabled, false_loops;
};

/// Feeds `synth` keyframe by keyframe (pose graph only): each node with the edges that end at it.
/// `settle`: then wait for the optimiser's own result once it has been quiet for ba.global_when_idle_s.
GraphRun feedGraph(const SynthGraph& synth, const MapOptimizerConfig& config, bool settle = false) {
  Collector results;
  GraphRun run;
  run.false_loops = synth.false_edge_ids;
  MapOptimizer optimizer(config, [&](const std::shared_ptr<const MapOptimization>& r) {
    run.solves += r->graph_solved ? 1 : 0;
    results(r);
  });
  uint64_t revision = 0;
  for (const PoseGraphNode& n : synth.graph.nodes()) {
    OptimizerBatch b;
    b.nodes.push_back({n.id, n.robot, n.T_map_kf, n.id == 0});
    for (const PoseGraphEdge& e : synth.graph.edges()) {
      if (std::max(e.from, e.to) != n.id) continue;
      b.edges.push_back(e);
      b.solve = b.solve || e.kind != EdgeKind::kOdometry;
    }
    revision = optimizer.submit(std::move(b));
    results.waitFor(revision);  // one keyframe at a time, as the server's ingest paces them
  }
  auto result = results.waitFor(revision);
  EXPECT_TRUE(result && result->revision >= revision) << "no result";
  if (!result) return run;
  run.local_at_end = result->local_solves;
  if (settle) {  // quiet: the whole-graph solve the neighbourhood solves put off, with a revision of its own
    result = results.waitFor(revision + 1);
    EXPECT_TRUE(result && result->revision > revision) << "no solve when quiet";
    run.settled = result && result->revision > revision && result->graph_solved;
  }
  run.skipped = result->solves_skipped;
  run.local = result->local_solves;
  run.local_refused = result->local_refused;
  run.disabled = result->graph.disabled_edges;
  double sum = 0.0;
  for (size_t i = 0; i < synth.node_ids.size(); ++i)
    sum += (result->graph.T_map_kf.at(synth.node_ids[i]).translation() - synth.T_map_kf_true[i].translation())
               .squaredNorm();
  run.rms_m = std::sqrt(sum / static_cast<double>(synth.node_ids.size()));
  return run;
}

/// Four laps of a circle with exact edges (noise_scale 0) and `false_loops` wrong ones, fed keyframe by
/// keyframe.
GraphRun feedCircle(double solve_above_chi2, int false_loops) {
  SynthGraphConfig c;
  c.keyframes = 400;
  c.keyframes_per_lap = 100;
  c.loop_every = 2;
  c.noise_scale = 0.0;
  c.false_loops = false_loops;
  c.seed = 5;
  MapOptimizerConfig config;
  config.ba.enabled = false;
  config.graph.solve_above_chi2 = solve_above_chi2;
  return feedGraph(makeSynthGraph(c), config);
}

// A loop the estimate already satisfies needs no whole-graph solve (its cost grows with the map);
// one it does not satisfy (here: every false loop) still gets one, and is disabled by it.
TEST(MapOptimizer, OnlyLoopsTheEstimateDoesNotSatisfyGetAWholeGraphSolve) {
  const GraphRun every = feedCircle(0.0, 4);
  const GraphRun gated = feedCircle(PoseGraphConfig{}.solve_above_chi2, 4);
  std::printf(
      "[ measured ] 400-keyframe circle, exact edges, 150 true + %zu false loops: solve after every loop: %d "
      "solves, rms %.4f m; solve_above_chi2 %.2f: %d solves (%d kept without one), rms %.4f m\n",
      gated.false_loops.size(), every.solves, every.rms_m, PoseGraphConfig{}.solve_above_chi2, gated.solves,
      gated.skipped, gated.rms_m);
  ASSERT_EQ(gated.false_loops.size(), 4u);
  EXPECT_EQ(every.skipped, 0);
  EXPECT_GE(every.solves, 150);
  EXPECT_GT(gated.skipped, 100) << "consistent loops were solved for";
  EXPECT_GE(gated.solves, 1) << "false loops must be judged by a solve";
  EXPECT_LE(gated.solves, 8);
  for (int64_t id : gated.false_loops)
    EXPECT_TRUE(std::count(gated.disabled.begin(), gated.disabled.end(), id))
        << "false loop " << id << " kept";
  EXPECT_EQ(gated.disabled.size(), every.disabled.size()) << "the gate changed which loops are kept";
  EXPECT_LT(gated.rms_m, every.rms_m + 0.005);
}

RGBDMAP_TEST_TIER("MapOptimizer.LoopsInARevisitedRoomAreSolvedInTheirNeighbourhood", "e2e");
// in a room many passes revisit (every keyframe with loops to 4 earlier passes, noisy edges, 3
// false loops), new loops are solved in their neighbourhood; only what the neighbourhood cannot explain (the
// false loops, drift it cannot absorb) goes to a whole-graph solve, which alone disables loops. Once quiet,
// the optimiser solves the whole graph by itself: same loops kept, same accuracy as solving it every time.
TEST(MapOptimizer, LoopsInARevisitedRoomAreSolvedInTheirNeighbourhood) {
  SynthGraphConfig c = revisitedRoom(46 * 6, 4, 11);
  c.false_loops = 3;
  const SynthGraph synth = makeSynthGraph(c);
  MapOptimizerConfig config;
  config.ba.enabled = false;
  config.graph.local_max_nodes = 0;
  const GraphRun whole = feedGraph(synth, config);
  config.graph.local_max_nodes = 100;
  config.ba.global_when_idle_s = 0.2;
  const GraphRun local = feedGraph(synth, config, true);
  std::printf(
      "[ measured ] %d keyframes, %zu loops (%zu false): whole graph only: %d solves, rms %.4f m, %zu "
      "disabled; "
      "local first (100 nodes): %d solves of which %d local (%d refused), then one when quiet: rms %.4f m, "
      "%zu "
      "disabled\n",
      c.keyframes, synth.loop_edge_ids.size(), synth.false_edge_ids.size(), whole.solves, whole.rms_m,
      whole.disabled.size(), local.solves, local.local, local.local_refused, local.rms_m,
      local.disabled.size());
  EXPECT_EQ(whole.local, 0);
  EXPECT_GT(local.local, 0) << "no neighbourhood solve was kept";
  EXPECT_LT(local.solves - local.local, whole.solves) << "as many whole-graph solves as without";
  EXPECT_GE(local.local_refused, 1) << "the false loops must go to the whole graph";
  for (const GraphRun* run : {&whole, &local})
    for (int64_t id : synth.false_edge_ids)
      EXPECT_TRUE(std::count(run->disabled.begin(), run->disabled.end(), id))
          << "false loop " << id << " kept";
  EXPECT_LE(local.disabled.size(), whole.disabled.size() + 2) << "true loops disabled";
  EXPECT_TRUE(local.settled);
  EXPECT_LT(local.rms_m, whole.rms_m + 0.002) << "after the whole-graph solve when quiet";
}

struct MergeRun {
  std::shared_ptr<const MapOptimization> result;
  int solves = 0;
  double max_error_m = 0.0;  ///< the new chain's keyframes against the truth
  std::vector<int64_t> wrong_edges;
};

/// A 400-keyframe circle (robot 0, exact edges, solved once), then a new chain of 10 keyframes that starts in
/// a frame of its own (5 m and 90 degrees off) and meets the circle through inter-robot edges from its first
/// keyframe; `wrong` of those edges are 1 m off.
MergeRun mergeChain(int wrong) {
  SynthGraphConfig c;
  c.keyframes = 400;
  c.keyframes_per_lap = 100;
  c.loop_every = 2;
  c.noise_scale = 0.0;
  c.seed = 5;
  const SynthGraph synth = makeSynthGraph(c);
  MapOptimizerConfig config;
  config.ba.enabled = false;
  Collector results;
  MergeRun run;
  MapOptimizer optimizer(config, [&](const std::shared_ptr<const MapOptimization>& r) {
    run.solves += r->graph_solved ? 1 : 0;
    results(r);
  });
  OptimizerBatch first;
  for (const PoseGraphNode& n : synth.graph.nodes())
    first.nodes.push_back({n.id, n.robot, n.T_map_kf, n.id == 0});
  first.edges = synth.graph.edges();
  first.solve = true;
  results.waitFor(optimizer.submit(std::move(first)));
  const int solves_before = run.solves;

  // The chain revisits keyframes 10..19 of the first lap; its own frame is T_off away from the map's.
  const SE3 T_off = se3::exp((Vec6() << 5.0, -2.0, 0.3, 0.0, 0.0, M_PI / 2).finished());
  int64_t edge_id = synth.next_edge_id + 1000;
  OptimizerBatch b;
  std::vector<std::pair<int64_t, SE3>> truth;
  for (int k = 0; k < 10; ++k) {
    const int64_t id = 10000 + k;
    const SE3& T_true = synth.T_map_kf_true[10 + k];
    truth.emplace_back(id, T_true);
    b.nodes.push_back({id, 7, T_off * T_true, false});
    if (k > 0) {
      const SE3& T_prev = synth.T_map_kf_true[9 + k];
      b.edges.push_back(
          backendEdge(edge_id++, id, id - 1, T_true.inverse() * T_prev, EdgeKind::kOdometry, 0.01, 0.01));
    }
  }
  for (int j = 0; j < 3; ++j) {  // the chain's first keyframe sees keyframes 110, 210 and 310 (laps 2-4)
    const int64_t to = synth.node_ids[110 + 100 * j];
    SE3 T_from_to = synth.T_map_kf_true[10].inverse() * synth.T_map_kf_true[110 + 100 * j];
    if (j < wrong) {
      T_from_to = T_from_to * se3::exp((Vec6() << 1.0, 0.0, 0.0, 0.0, 0.0, 0.0).finished());
      run.wrong_edges.push_back(edge_id);
    }
    b.edges.push_back(backendEdge(edge_id++, 10000, to, T_from_to, EdgeKind::kInterRobot, 0.01, 0.01));
  }
  b.solve = true;
  b.merge = true;
  run.result = results.waitFor(optimizer.submit(std::move(b)));
  run.solves -= solves_before;
  if (!run.result) return run;
  for (const auto& [id, T_true] : truth)
    run.max_error_m = std::max(
        run.max_error_m, (run.result->graph.T_map_kf.at(id).translation() - T_true.translation()).norm());
  return run;
}

// a robot's new chain meeting a large map for the first time is moved onto it rigidly; when its
// edges then agree with the map, no whole-graph solve follows. One edge that disagrees still gets a solve
// (which disables it): the rigid move never decides alone.
TEST(MapOptimizer, AChainMeetingALargeMapIsMovedRigidlyAndSolvedOnlyIfItsEdgesDisagree) {
  const MergeRun clean = mergeChain(0);
  const MergeRun wrong = mergeChain(1);
  ASSERT_TRUE(clean.result && wrong.result);
  std::printf(
      "[ measured ] new chain onto a 400-keyframe map: %d solve(s), %d merge(s) aligned, max error %.2e m; "
      "with one wrong edge of three: %d solve(s), %zu backendEdge(s) disabled, max error %.2e m\n",
      clean.solves, clean.result->merges_aligned, clean.max_error_m, wrong.solves,
      wrong.result->graph.disabled_edges.size(), wrong.max_error_m);
  EXPECT_EQ(clean.solves, 0) << "the merge alone explained the edges";
  EXPECT_EQ(clean.result->merges_aligned, 1);
  EXPECT_LT(clean.max_error_m, 1e-6);
  ASSERT_EQ(clean.result->graph.components.size(), 1u) << "one map";
  EXPECT_EQ(wrong.solves, 1);
  EXPECT_EQ(wrong.result->graph.disabled_edges, wrong.wrong_edges);
  EXPECT_LT(wrong.max_error_m, 1e-3);
  EXPECT_EQ(wrong.result->graph.components.size(), 1u);
}

}  // namespace
}  // namespace rgbdmap
