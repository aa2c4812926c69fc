// Synthetic loops: drift removal, exact recovery, injected false loops (rgbdmap_pose_graph).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>

#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_synth.hpp"

namespace rgbdmap {
namespace {

SynthGraphConfig circle(int keyframes, int false_loops, uint32_t seed, int per_lap = 100) {
  SynthGraphConfig c;
  c.keyframes = keyframes;
  c.keyframes_per_lap = per_lap;
  c.loop_every = 5;
  c.false_loops = false_loops;
  c.seed = seed;
  return c;
}

double positionRms(const PoseGraph& a, const PoseGraph& b) {
  double sum = 0.0;
  for (const auto& n : a.nodes())
    sum += (n.T_map_kf.translation() - b.pose(n.id)->translation()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(a.nodes().size()));
}

// 200 keyframes on four laps of a 5 m circle, 30 loops: the loops remove most of the odometry drift.
TEST(PoseGraphLoops, CircleWithNoisyOdometryRemovesDrift) {
  for (uint32_t seed : {1u, 2u, 3u, 4u, 5u}) {
    SynthGraph synth = makeSynthGraph(circle(200, 0, seed, 50));
    ASSERT_TRUE(synth.graph.setFixed(0).ok());
    const double ate_odometry = translationRmse(synth.graph, synth);
    auto report = synth.graph.optimize(PoseGraphConfig{});
    ASSERT_TRUE(report.ok()) << report.error();
    const double ate = translationRmse(synth.graph, synth);
    ::testing::Test::RecordProperty("ate_odometry_m_seed" + std::to_string(seed),
                                    std::to_string(ate_odometry));
    ::testing::Test::RecordProperty("ate_optimised_m_seed" + std::to_string(seed), std::to_string(ate));
    EXPECT_LT(ate, 0.3 * ate_odometry)
        << "seed " << seed << " odometry " << ate_odometry << " optimised " << ate;
    EXPECT_EQ(report->loops_total, 30);
    EXPECT_LE(report->loops_rejected, 1) << "at most one correct loop past the 99.9% quantile";
    EXPECT_LT(report->final_cost, report->initial_cost);
  }
}

// Noise-free edges from a heavily perturbed start: the optimum is the ground truth.
TEST(PoseGraphLoops, NoiseFreeEdgesRecoverGroundTruth) {
  SynthGraphConfig c = circle(200, 0, 4);
  c.noise_scale = 0.0;
  SynthGraph synth = makeSynthGraph(c);
  ASSERT_TRUE(synth.graph.setFixed(0).ok());
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 1.0);
  for (size_t k = 1; k < synth.node_ids.size(); ++k) {
    Vec6 d;
    for (int i = 0; i < 6; ++i) d[i] = n(rng) * (i < 3 ? 0.3 : 0.1);
    ASSERT_TRUE(synth.graph.setPose(synth.node_ids[k], se3::exp(d) * synth.T_map_kf_true[k]).ok());
  }
  const double ate_start = translationRmse(synth.graph, synth);
  auto report = synth.graph.optimize(PoseGraphConfig{});
  ASSERT_TRUE(report.ok()) << report.error();
  const double ate = translationRmse(synth.graph, synth);
  EXPECT_GT(ate_start, 0.3);
  EXPECT_LT(ate, 1e-5);
  EXPECT_EQ(report->loops_rejected, 0);
}

void checkFalseLoops(const PoseGraphConfig& config, uint32_t seed) {
  // 3 laps: 40 correct loops, 6 false ones (13%) claiming that far-apart keyframes coincide.
  SynthGraph clean = makeSynthGraph(circle(300, 0, seed));
  SynthGraph dirty = makeSynthGraph(circle(300, 6, seed));  // same odometry and correct loops
  ASSERT_TRUE(clean.graph.setFixed(0).ok());
  ASSERT_TRUE(dirty.graph.setFixed(0).ok());
  ASSERT_TRUE(clean.graph.optimize(config).ok());
  auto report = dirty.graph.optimize(config);
  ASSERT_TRUE(report.ok()) << report.error();
  const double ate_clean = translationRmse(clean.graph, clean),
               ate_dirty = translationRmse(dirty.graph, dirty);
  const double offset = positionRms(dirty.graph, clean.graph);
  ::testing::Test::RecordProperty("ate_clean_m", std::to_string(ate_clean));
  ::testing::Test::RecordProperty("ate_with_false_loops_m", std::to_string(ate_dirty));
  ::testing::Test::RecordProperty("rms_offset_from_clean_m", std::to_string(offset));
  EXPECT_LT(offset, 0.01) << "false loops moved the map; clean ATE " << ate_clean << " dirty " << ate_dirty;
  const auto& disabled = dirty.graph.disabledEdges();
  for (int64_t id : dirty.false_edge_ids) {
    EXPECT_TRUE(std::count(disabled.begin(), disabled.end(), id)) << "false loop " << id << " kept";
  }
  EXPECT_LE(disabled.size(), dirty.false_edge_ids.size() + 1) << "more than one correct loop rejected";
  EXPECT_EQ(report->rejected_edge_ids, disabled);
}

TEST(PoseGraphLoops, FalseLoopsAreDisabledCauchy) {
  for (uint32_t seed : {5u, 6u, 7u}) checkFalseLoops(PoseGraphConfig{}, seed);
}

TEST(PoseGraphLoops, FalseLoopsAreDisabledHuber) {
  PoseGraphConfig config;
  config.use_cauchy = false;
  checkFalseLoops(config, 8);
}

// Without the consistency check the robust loss alone still bounds the damage, but the map is worse.
TEST(PoseGraphLoops, RobustLossAloneKeepsFalseLoopsButBoundsDamage) {
  PoseGraphConfig config;
  config.max_outlier_rounds = 0;
  SynthGraph dirty = makeSynthGraph(circle(300, 6, 5));
  ASSERT_TRUE(dirty.graph.setFixed(0).ok());
  auto report = dirty.graph.optimize(config);
  ASSERT_TRUE(report.ok());
  EXPECT_EQ(report->loops_rejected, 0);
  EXPECT_LT(translationRmse(dirty.graph, dirty), 0.5);
}

}  // namespace
}  // namespace rgbdmap

namespace rgbdmap {
namespace {

// A solve stopped by max_solver_time_s (a loaded machine, a large graph) leaves the poses between odometry
// and the solution: judged there, true loops look inconsistent. It must disable none (a 2 s cap
// disabled 5,371 of 37,000 true loops on an 8k graph); the next converged solve still rejects false ones.
TEST(PoseGraphLoops, ASolveOutOfTimeDisablesNoLoop) {
  SynthGraph synth = makeSynthGraph(circle(1000, 0, 11, 100));
  ASSERT_TRUE(synth.graph.setFixed(0).ok());
  const double ate_odometry = translationRmse(synth.graph, synth);
  PoseGraphConfig rushed;
  rushed.max_solver_time_s = 0.001;
  auto cut = synth.graph.optimize(rushed);
  ASSERT_TRUE(cut.ok()) << cut.error();
  ASSERT_TRUE(cut->out_of_time) << "the graph solved in 1 ms: make it larger";
  EXPECT_EQ(cut->loops_rejected, 0) << "loops judged by an unfinished solve";
  EXPECT_TRUE(synth.graph.disabledEdges().empty());
  EXPECT_LE(translationRmse(synth.graph, synth), ate_odometry) << "the partial solve's poses made it worse";
  // What a check there would have judged: many true loops far above the threshold.
  int inconsistent = 0;
  for (int64_t id : synth.loop_edge_ids)
    inconsistent += *synth.graph.edgeChi2(id) > PoseGraphConfig{}.outlier_chi2 ? 1 : 0;
  std::printf("[ measured ] after a 1 ms solve %d of %zu true loops are above the outlier threshold\n",
              inconsistent, synth.loop_edge_ids.size());
  EXPECT_GT(inconsistent, 10) << "the unfinished solve was nearly done: the test shows nothing";
  // Given its time, the same graph converges with (nearly) every true loop kept: the 99.9% threshold may
  // take one of these 180. The solves below are bounded by iterations, not by the 2 s default: under the
  // sanitizers on a loaded CI machine a 1,000-keyframe solve may take longer, run out of time and judge
  // nothing, which is the behaviour above, not what this part tests.
  PoseGraphConfig untimed;
  untimed.max_solver_time_s = 600.0;
  auto full = synth.graph.optimize(untimed);
  ASSERT_TRUE(full.ok()) << full.error();
  EXPECT_FALSE(full->out_of_time);
  EXPECT_LE(full->loops_rejected, 2);
  EXPECT_LT(translationRmse(synth.graph, synth), 0.1 * ate_odometry);
  // False loops are still rejected by converged solves after an unfinished one.
  SynthGraph with_false = makeSynthGraph(circle(1000, 10, 12, 100));
  ASSERT_TRUE(with_false.graph.setFixed(0).ok());
  ASSERT_TRUE(with_false.graph.optimize(rushed).ok());
  auto judged = with_false.graph.optimize(untimed);
  ASSERT_TRUE(judged.ok()) << judged.error();
  ASSERT_FALSE(judged->out_of_time);
  for (int64_t id : with_false.false_edge_ids)
    EXPECT_TRUE(std::binary_search(judged->rejected_edge_ids.begin(), judged->rejected_edge_ids.end(), id))
        << "false loop " << id << " kept";
}

}  // namespace
}  // namespace rgbdmap

namespace rgbdmap {
namespace {

PoseGraphConfig untimedConfig() {
  PoseGraphConfig c;
  c.max_solver_time_s = 600.0;  // bounded by iterations: the same answer under the sanitizers
  return c;
}

// A solve stopped by max_iterations is as unfinished as one out of time: it judges no loop either.
TEST(PoseGraphLoops, ASolveStoppedByItsIterationLimitDisablesNoLoop) {
  SynthGraph synth = makeSynthGraph(circle(300, 6, 21));
  ASSERT_TRUE(synth.graph.setFixed(0).ok());
  PoseGraphConfig short_config = untimedConfig();
  short_config.max_iterations = 1;
  auto cut = synth.graph.optimize(short_config);
  ASSERT_TRUE(cut.ok()) << cut.error();
  EXPECT_TRUE(cut->iteration_limit);
  EXPECT_FALSE(cut->out_of_time);
  EXPECT_EQ(cut->loops_rejected, 0);
  auto full = synth.graph.optimize(untimedConfig());
  ASSERT_TRUE(full.ok()) << full.error();
  EXPECT_FALSE(full->iteration_limit);
  for (int64_t id : synth.false_edge_ids)
    EXPECT_TRUE(std::binary_search(full->rejected_edge_ids.begin(), full->rejected_edge_ids.end(), id))
        << "false loop " << id << " kept";
}

// Conjugate gradients forced onto a long chain (5 laps of 200 keyframes, a loop every 5th): block Jacobi
// needs the whole CG cap there, the solve switches to the spanning-tree preconditioner and ends where
// sparse Cholesky ends, false loops rejected alike.
TEST(PoseGraphLoops, ConjugateGradientsOnALongChainSwitchToTheTreeAndMatchCholesky) {
  const SynthGraph synth = makeSynthGraph(circle(1000, 10, 12, 200));
  PoseGraph cholesky = synth.graph, cg = synth.graph;
  ASSERT_TRUE(cholesky.setFixed(0).ok() && cg.setFixed(0).ok());
  PoseGraphConfig exact = untimedConfig();
  exact.iterative_min_edges_per_node = 0.0;
  PoseGraphConfig iterative = untimedConfig();
  iterative.iterative_min_edges_per_node = 0.5;
  auto a = cholesky.optimize(exact);
  auto b = cg.optimize(iterative);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->tree_preconditioned_solves, 0);
  EXPECT_GE(b->tree_preconditioned_solves, 1) << "block Jacobi sufficed: the chain is too short to show it";
  EXPECT_FALSE(b->iteration_limit);
  const double ate = translationRmse(cholesky, synth);
  std::printf("[ measured ] ATE Cholesky %.4f m, CG %.4f m, positions apart %.5f m; rejected %d vs %d\n", ate,
              translationRmse(cg, synth), positionRms(cholesky, cg), a->loops_rejected, b->loops_rejected);
  EXPECT_LT(positionRms(cholesky, cg), 0.05 * ate);
  EXPECT_EQ(a->rejected_edge_ids, b->rejected_edge_ids);
  for (int64_t id : synth.false_edge_ids)
    EXPECT_TRUE(std::binary_search(b->rejected_edge_ids.begin(), b->rejected_edge_ids.end(), id));
}

}  // namespace
}  // namespace rgbdmap
