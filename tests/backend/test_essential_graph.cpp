// The essential-graph edge rewrite and the check of an adjustment's outcome, on a synthetic scene with exact
// ground truth (ba_synth): edges between keyframes that share landmarks take an outcome's relative poses,
// an edge into keyframes sharing none keeps its measurement, an outcome that moves a covisible edge beyond
// max_edge_change_m is refused, step priors are the edges the landmarks do not cover.
#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "backend/backend_test_util.hpp"
#include "rgbdmap/ba/ba_synth.hpp"
#include "rgbdmap/backend/bundle_outcome.hpp"
#include "rgbdmap/backend/essential_graph.hpp"

namespace rgbdmap {
namespace {

using testing::backendEdge;

/// Keyframes 0-1-2 share landmarks (true matches 0-1, 1-2); keyframe 3 is in the graph and the landmark map
/// but shares none. Odometry edges at the true relative poses.
struct Scene {
  BaSynthScene s;
  PoseGraph graph;
  LandmarkMap landmarks;
  MapTopology topology;
  EssentialGraph essential{&graph, &landmarks, &topology};
  BundleAdjustmentConfig config;
  BundleOutcome outcome{&config, &graph, &landmarks, &topology, &essential};

  Scene() : s(scene()) {
    for (int k = 0; k < 4; ++k) {
      EXPECT_TRUE(graph.addNode(k, 0, s.T_map_kf[k]));
      topology.addNode(k, 0);
      EXPECT_TRUE(landmarks.addKeyframe(synthKeyframe(s, k, s.T_map_kf[k])));
      if (k == 0) continue;
      const PoseGraphEdge e =
          backendEdge(k - 1, k, k - 1, s.T_map_kf[k].inverse() * s.T_map_kf[k - 1], EdgeKind::kOdometry);
      EXPECT_TRUE(graph.addEdge(e));
      topology.addEdge(e);
    }
    topology.refresh(graph);
    landmarks.addMatches(synthTrueMatches(s, 0, 1));
    landmarks.addMatches(synthTrueMatches(s, 1, 2));
  }
  static BaSynthScene scene() {
    BaSynthConfig c;
    c.keyframes = 4;
    c.points = 800;
    return makeBaSynthScene(c);
  }
  /// Keyframe k moved by dx along x.
  std::pair<int64_t, SE3> moved(int k, double dx) const {
    SE3 T = s.T_map_kf[k];
    T.translation().x() += dx;
    return {k, T};
  }
};

TEST(EssentialGraph, CovisibleEdgesOfMovedKeyframesOnceWithTheirChange) {
  Scene t;
  ASSERT_GT(t.landmarks.sharedLandmarks(1, 2), 0);
  ASSERT_EQ(t.landmarks.sharedLandmarks(2, 3), 0);
  const std::vector<CovisibleEdge> edges =
      t.essential.covisibleEdgeChanges({t.moved(1, 0.1), t.moved(2, 0.1)});
  std::vector<int64_t> ids;
  for (const CovisibleEdge& c : edges) ids.push_back(c.edge->id);
  EXPECT_EQ(ids, (std::vector<int64_t>{0, 1}));  // 0-1 and 1-2 once; 2-3 shares no landmarks
  EXPECT_NEAR(edges[0].t, 0.1, 1e-9);            // 1 moved, 0 did not
  EXPECT_NEAR(edges[1].t, 0.0, 1e-9);            // 1 and 2 moved together
}

TEST(EssentialGraph, AnAppliedOutcomeRewritesCovisibleEdgesItSawOnly) {
  Scene t;
  const auto [id, T] = t.moved(2, 0.05);
  t.landmarks.setPose(id, 0, T);
  BundleResult r;
  r.ok = true;
  r.moved = {2};
  r.fixed = {1};
  const SE3 before_23 = t.graph.edge(2)->T_from_to;
  t.essential.apply(r, nullptr);
  EXPECT_TRUE(t.graph.pose(2)->isApprox(T));
  const SE3 expected_12 = T.inverse() * t.s.T_map_kf[1];
  EXPECT_TRUE(t.graph.edge(1)->T_from_to.isApprox(expected_12, 1e-9));  // covisible, both seen
  EXPECT_TRUE(t.graph.edge(2)->T_from_to.isApprox(before_23));          // 3 shares no landmarks
}

TEST(BundleOutcome, AnOutcomeMovingACovisibleEdgeTooFarIsRefusedAndItsEdgesAreKeptForItsApply) {
  Scene t;
  t.config.max_edge_change_m = 0.05;
  EXPECT_NE(t.outcome.check({t.moved(1, 0.1)}), "");
  EXPECT_EQ(t.outcome.check({t.moved(1, 0.01)}), "");
  ASSERT_NE(t.outcome.checkedEdges({1}), nullptr);
  EXPECT_EQ(t.outcome.checkedEdges({1})->size(), 2u);
  EXPECT_EQ(t.outcome.checkedEdges({2}), nullptr);  // another outcome: its edges are found when applied
  t.outcome.forget();
  EXPECT_EQ(t.outcome.checkedEdges({1}), nullptr);
  t.config.max_edge_change_m = 0.0;  // no check
  t.config.max_edge_change_deg = 0.0;
  EXPECT_EQ(t.outcome.check({t.moved(1, 3.0)}), "");
}

TEST(BundleOutcome, CountsRefusedAndKeptPartsAndAppliesOnlyOkOutcomes) {
  BundleAdjustmentStats counters;
  BundleResult refused;
  refused.refused = true;
  refused.parts_kept = 2;
  refused.part_shift_m = 0.3;
  EXPECT_FALSE(BundleOutcome::count(refused, "local", &counters));
  BundleResult ok;
  ok.ok = true;
  ok.part_shift_m = 0.1;
  EXPECT_TRUE(BundleOutcome::count(ok, "global", &counters));
  EXPECT_EQ(counters.refused, 1);
  EXPECT_EQ(counters.parts_kept, 2);
  EXPECT_DOUBLE_EQ(counters.part_shift_m_max, 0.3);
}

TEST(BundleOutcome, StepPriorsAreTheEdgesTheLandmarksDoNotCoverWhenOn) {
  Scene t;
  EXPECT_TRUE(t.outcome.stepPriors(0).empty());  // off by default
  t.config.global_step_priors = true;
  const std::vector<BundlePrior> priors = t.outcome.stepPriors(0);
  ASSERT_EQ(priors.size(), 1u);
  EXPECT_EQ(priors[0].from, 3);
  EXPECT_EQ(priors[0].to, 2);
  EXPECT_TRUE(t.outcome.stepPriors(7).empty());  // no such map
}

}  // namespace
}  // namespace rgbdmap
