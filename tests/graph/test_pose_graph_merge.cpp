// Two robots: inter-robot loop edges merge their maps into one component (rgbdmap_pose_graph).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_synth.hpp"

namespace rgbdmap {
namespace {

constexpr int64_t kRobot1FirstId = 1000;

SE3 robot1Start() { return se3::exp((Vec6() << 1.0, 0.5, 0.0, 0.0, 0.0, 0.4).finished()); }

/// Robot 0 from the map origin, robot 1 on an overlapping circle; robot 1's poses start in its own
/// odometry frame (its first keyframe at the identity), as a robot that has not met the others yet.
SynthGraph twoRobots(uint32_t seed) {
  SynthGraphConfig c;
  c.keyframes = 150;
  c.keyframes_per_lap = 50;
  c.seed = seed;
  SynthGraph synth = makeSynthGraph(c);
  c.robot = 1;
  c.first_node_id = kRobot1FirstId;
  c.T_map_start = robot1Start();
  c.seed = seed + 100;
  appendSynthRobot(c, &synth);
  const SE3 T_odom1_map = synth.T_map_kf_true[150].inverse();
  for (const auto& node : std::vector<PoseGraphNode>(synth.graph.nodes())) {
    if (node.robot == 1) synth.graph.setPose(node.id, T_odom1_map * node.T_map_kf);
  }
  synth.graph.setFixed(0);
  return synth;
}

/// Inter-robot loops from every 10th robot-1 keyframe to the nearest robot-0 keyframe within 1.5 m.
std::vector<int64_t> addInterRobotLoops(SynthGraph* s, int false_ones, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<int64_t> false_ids;
  for (size_t b = 150; b < s->node_ids.size(); b += 10) {
    size_t best = 0;
    for (size_t a = 0; a < 150; ++a) {
      const auto d = [&](size_t i) {
        return (s->T_map_kf_true[i].translation() - s->T_map_kf_true[b].translation()).norm();
      };
      if (d(a) < d(best)) best = a;
    }
    if ((s->T_map_kf_true[best].translation() - s->T_map_kf_true[b].translation()).norm() > 1.5) continue;
    Vec6 d;
    for (int i = 0; i < 6; ++i) d[i] = n(rng) * (i < 3 ? 0.01 : 0.004);
    PoseGraphEdge e;
    e.id = s->next_edge_id++;
    e.from = s->node_ids[best];
    e.to = s->node_ids[b];
    e.T_from_to = se3::exp(d) * s->T_map_kf_true[best].inverse() * s->T_map_kf_true[b];
    e.information = diagonalInformation(0.01, 0.004);
    e.kind = EdgeKind::kInterRobot;
    if (static_cast<int>(false_ids.size()) < false_ones) {  // claims the two keyframes coincide
      e.T_from_to = se3::exp(d * 10.0);
      e.from = s->node_ids[(best + 25) % 150];
      false_ids.push_back(e.id);
    }
    EXPECT_TRUE(s->graph.addEdge(e).ok());
  }
  return false_ids;
}

/// Robot of a node id in these graphs.
int robotOf(int64_t id) { return id >= kRobot1FirstId ? 1 : 0; }

bool hasRobot(const std::vector<int64_t>& ids, int robot) {
  return std::any_of(ids.begin(), ids.end(), [robot](int64_t id) { return robotOf(id) == robot; });
}

TEST(PoseGraphMerge, WithoutInterRobotEdgesTwoGaugeFixedComponents) {
  SynthGraph synth = twoRobots(11);
  const auto components = synth.graph.components();
  ASSERT_EQ(components.size(), 2u);
  EXPECT_EQ(components[0].front(), 0);
  EXPECT_EQ(components[1].front(), kRobot1FirstId);
  const SE3 T_first1 = *synth.graph.pose(kRobot1FirstId);
  auto report = synth.graph.optimize(PoseGraphConfig{});
  ASSERT_TRUE(report.ok()) << report.error();
  EXPECT_EQ(report->merged_submaps, 0);
  EXPECT_TRUE(synth.graph.pose(kRobot1FirstId)->isApprox(T_first1, 1e-12)) << "robot 1's gauge moved";
  EXPECT_TRUE(synth.graph.pose(0)->isApprox(synth.T_map_kf_true[0], 1e-12));
  EXPECT_LT(translationRmse(synth.graph, synth, 0), 0.15);
  EXPECT_GT(translationRmse(synth.graph, synth, 1), 0.5) << "robot 1 is still in its own frame";
}

void expectMerged(SynthGraph* synth, const std::vector<int64_t>& false_ids) {
  auto report = synth->graph.optimize(PoseGraphConfig{});
  ASSERT_TRUE(report.ok()) << report.error();
  EXPECT_EQ(report->merged_submaps, 1);
  const auto components = synth->graph.components();
  ASSERT_EQ(components.size(), 1u);
  EXPECT_TRUE(hasRobot(components[0], 0) && hasRobot(components[0], 1));
  const double ate0 = translationRmse(synth->graph, *synth, 0),
               ate1 = translationRmse(synth->graph, *synth, 1);
  ::testing::Test::RecordProperty("ate_robot0_m", std::to_string(ate0));
  ::testing::Test::RecordProperty("ate_robot1_m", std::to_string(ate1));
  EXPECT_LT(ate0, 0.15);
  EXPECT_LT(ate1, 0.15) << "robot 1 not placed in the shared map";
  for (int64_t id : false_ids) {
    const auto& disabled = synth->graph.disabledEdges();
    EXPECT_TRUE(std::count(disabled.begin(), disabled.end(), id))
        << "false inter-robot loop " << id << " kept";
  }
  // A second optimisation of the merged map does not move it again.
  auto again = synth->graph.optimize(PoseGraphConfig{});
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->merged_submaps, 0);
  EXPECT_NEAR(translationRmse(synth->graph, *synth, 1), ate1, 1e-3);
}

TEST(PoseGraphMerge, InterRobotEdgesMergeIntoOneComponent) {
  SynthGraph synth = twoRobots(12);
  addInterRobotLoops(&synth, 0, 1);
  expectMerged(&synth, {});
}

TEST(PoseGraphMerge, MergeSurvivesAFalseInterRobotLoop) {
  SynthGraph synth = twoRobots(13);
  const auto false_ids = addInterRobotLoops(&synth, 2, 2);
  ASSERT_EQ(false_ids.size(), 2u);
  expectMerged(&synth, false_ids);
}

}  // namespace
}  // namespace rgbdmap
