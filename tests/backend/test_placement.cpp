// Placement rules of a localising robot (rgbdmap/backend/placement.hpp): a first placement needs agreeing
// votes of distinct map keyframes and no contradicting one; once placed, votes are gated by the prediction.
#include <gtest/gtest.h>

#include <vector>

#include "rgbdmap/backend/placement.hpp"

namespace rgbdmap {
namespace {

SE3 pose(double x, double y, double yaw_deg) {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Vec3::UnitZ()).toRotationMatrix();
  T.translation() = Vec3(x, y, 0.0);
  return T;
}

TEST(Placement, TwoAgreeingMapKeyframesPlaceAtTheirWeightedMean) {
  const std::vector<PlacementVote> votes = {{3, 0, pose(1.00, 2.00, 10.0), 100},
                                            {4, 0, pose(1.02, 2.00, 11.0), 300}};
  const auto e = placeKeyframe(votes, std::nullopt, PlacementConfig{});
  ASSERT_TRUE(e);
  EXPECT_EQ(e->map_id, 0);
  EXPECT_EQ(e->agreeing, 2);
  EXPECT_NEAR(e->T_map_kf.translation().x(), 1.015, 1e-9);  // inlier-weighted
  EXPECT_TRUE(posesAgree(e->T_map_kf, pose(1.015, 2.0, 10.75), 1e-6, 0.01));
}

TEST(Placement, OneVoteOrTwoOfTheSameMapKeyframeDoNotPlace) {
  const PlacementConfig config;
  EXPECT_FALSE(placeKeyframe({{3, 0, pose(1, 2, 0), 500}}, std::nullopt, config));
  EXPECT_FALSE(
      placeKeyframe({{3, 0, pose(1, 2, 0), 500}, {3, 0, pose(1.01, 2, 0), 90}}, std::nullopt, config));
  EXPECT_FALSE(placeKeyframe({}, std::nullopt, config));
}

TEST(Placement, VotesThatDisagreeOrContradictDoNotPlace) {
  const PlacementConfig config;
  // Two map keyframes 30 cm apart on the robot's pose: no agreement.
  EXPECT_FALSE(
      placeKeyframe({{3, 0, pose(1, 2, 0), 100}, {4, 0, pose(1.3, 2, 0), 100}}, std::nullopt, config));
  // Two agree but a third puts the robot elsewhere (a place that looks like two): not placed.
  EXPECT_FALSE(
      placeKeyframe({{3, 0, pose(1, 2, 0), 100}, {4, 0, pose(1.01, 2, 0), 100}, {9, 0, pose(4, 2, 90), 80}},
                    std::nullopt, config));
  // ... or in another map.
  EXPECT_FALSE(
      placeKeyframe({{3, 0, pose(1, 2, 0), 100}, {4, 0, pose(1.01, 2, 0), 100}, {9, 7, pose(1, 2, 0), 80}},
                    std::nullopt, config));
  PlacementConfig one;
  one.first_min_agreeing = 1;
  EXPECT_TRUE(placeKeyframe({{3, 0, pose(1, 2, 0), 100}}, std::nullopt, one));
}

TEST(Placement, OncePlacedVotesWithinTheGateOfThePredictionAreBelieved) {
  const PlacementConfig config;
  const PlacementEstimate predicted{0, pose(1, 2, 0), 0};
  const auto near = placeKeyframe({{3, 0, pose(1.05, 2, 2), 100}}, predicted, config);
  ASSERT_TRUE(near);
  EXPECT_EQ(near->agreeing, 1);
  EXPECT_NEAR(near->T_map_kf.translation().x(), 1.05, 1e-9);
  EXPECT_FALSE(placeKeyframe({{3, 0, pose(1.5, 2, 0), 100}}, predicted, config));  // beyond track_gate_m
  EXPECT_FALSE(placeKeyframe({{3, 0, pose(1, 2, 30), 100}}, predicted, config));   // beyond track_gate_deg
  EXPECT_FALSE(placeKeyframe({{3, 5, pose(1, 2, 0), 100}}, predicted, config));    // another map
}

TEST(Placement, WeightedMeanPoseIsARotation) {
  const SE3 m = weightedMeanPose({pose(0, 0, 0), pose(0, 0, 90)}, {1.0, 1.0});
  EXPECT_NEAR(m.linear().determinant(), 1.0, 1e-9);
  EXPECT_TRUE(posesAgree(m, pose(0, 0, 45), 1e-9, 1e-6));
  const auto best = bestVote({{1, 0, pose(0, 0, 0), 10}, {2, 0, pose(1, 0, 0), 50}});
  ASSERT_TRUE(best);
  EXPECT_NEAR(best->T_map_kf.translation().x(), 1.0, 1e-12);
}

}  // namespace
}  // namespace rgbdmap
