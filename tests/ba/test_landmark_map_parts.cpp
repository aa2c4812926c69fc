// Bundle adjustment beyond the tracks: a rolling shutter estimated per keyframe, parts of the map that no
// held keyframe observes (kept in place, or placed by a prior between parts), and a refused adjustment.
#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <utility>

#include "ba/landmark_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::addScene;
using testing::BaScene;
using testing::BaSceneOptions;
using testing::makeBaScene;
using testing::perturbed;
using testing::posesOf;
using testing::positionRms;
using testing::sceneKeyframe;
using testing::trueMatches;

/// 12 keyframes whose images have a rolling shutter of 0.03 rad (~1 rad/s over a 30 ms readout), and start
/// poses 2 cm and 0.01 rad off theirs.
constexpr int kRollingShutterKeyframes = 12;
struct RollingShutterCase {
  BaScene s;
  std::vector<SE3> start;
};
RollingShutterCase rollingShutterCase() {
  BaSceneOptions o;
  o.keyframes = kRollingShutterKeyframes;
  o.rolling_shutter_rad = 0.03;
  RollingShutterCase c{makeBaScene(o), {}};
  c.start = perturbed(c.s, 0.02, 0.01, 13);
  return c;
}

/// One run of the case: its scene in a map with the rolling-shutter model on or off and the prior's sigma,
/// the priors centred by `centre` (null: 0), adjusted twice. The keyframes' position RMS (m) and the mean
/// error of their rolling-shutter rotations (rad); with `remove_mean` each side's mean rotation is taken out
/// first (a rotation common to every keyframe is nearly a gauge freedom of the scene: a vertical stretch of
/// a world seen from sideways-moving cameras).
struct RollingShutterRun {
  double rms = 0.0, w_err = 0.0;
};
RollingShutterRun runCase(const RollingShutterCase& c, bool model, double sigma,
                          const std::function<Vec3(int)>& centre, bool remove_mean) {
  LandmarkMapConfig config;
  config.solve.rolling_shutter = model;
  config.solve.rolling_shutter_sigma_rad = sigma;
  LandmarkMap map(config);
  addScene(&map, c.s, c.start, 0, centre);
  for (int round = 0; round < 2; ++round) EXPECT_TRUE(map.globalAdjust(0, 0).ok);
  const auto truth = [&](int k) { return c.s.rolling_shutter[static_cast<size_t>(k)]; };
  Vec3 mean_est = Vec3::Zero(), mean_true = Vec3::Zero();
  if (remove_mean)
    for (int k = 0; k < kRollingShutterKeyframes; ++k) {
      mean_est += *map.rollingShutter(k) / kRollingShutterKeyframes;
      mean_true += truth(k) / kRollingShutterKeyframes;
    }
  RollingShutterRun r;
  for (int k = 0; k < kRollingShutterKeyframes; ++k)
    r.w_err +=
        ((*map.rollingShutter(k) - mean_est) - (truth(k) - mean_true)).norm() / kRollingShutterKeyframes;
  r.rms = positionRms(c.s.T_map_kf, posesOf(map, c.s.T_map_kf.size()));
  return r;
}

/// Prints both runs; `better` must cut both errors below `factor` times `worse`'s.
void expectBetter(const char* what, const RollingShutterRun& worse, const RollingShutterRun& better,
                  double factor) {
  std::printf("[ measured ] %s: rms %.5f -> %.5f m, w error %.4f -> %.4f rad\n", what, worse.rms, better.rms,
              worse.w_err, better.w_err);
  EXPECT_LT(better.rms, factor * worse.rms);
  EXPECT_LT(better.w_err, factor * worse.w_err);
}

TEST(LandmarkMap, RollingShutterRotationIsEstimated) {
  const RollingShutterCase c = rollingShutterCase();
  // A loose prior (sigma 0.05) for a strong rolling shutter (0.03 rad) to recover.
  expectBetter("rolling shutter 0.03 rad, the model off -> on", runCase(c, false, 0.05, nullptr, true),
               runCase(c, true, 0.05, nullptr, true), 0.25);
}

// With a tight prior, w stays near the prior's centre: centred on what the camera's motion
// predicts (here the true rotation with a 15 % error, as the odometry's angular velocity gives it), the
// rolling shutter is recovered; centred on 0 (no readout time: a global shutter) it is not.
TEST(LandmarkMap, RollingShutterPriorCentredOnThePredictionRecoversTheRotation) {
  const RollingShutterCase c = rollingShutterCase();
  const auto prediction = [&](int k) {
    const Vec3& w = c.s.rolling_shutter[static_cast<size_t>(k)];
    return Vec3(0.85 * w + 0.15 * w.norm() * Vec3(w.y(), w.z(), w.x()).normalized());
  };
  expectBetter("rolling shutter 0.03 rad, prior sigma 0.0025 centred on 0 -> on the prediction",
               runCase(c, true, 0.0025, nullptr, false), runCase(c, true, 0.0025, prediction, false), 0.5);
}

// A chain's first keyframe has no step before it to predict its rolling shutter from; its prior's centre
// comes later (from the step after it). The map's anchor holds its w: at 0 it bends the map, at the late
// centre not. A keyframe whose w an adjustment estimated keeps it when its centre moves.
TEST(LandmarkMap, AChainsFirstKeyframeTakesItsRollingShutterPriorLater) {
  const RollingShutterCase c = rollingShutterCase();
  const BaScene& s = c.s;
  const std::vector<SE3>& start = c.start;
  const auto truth = [&](int k) { return s.rolling_shutter[static_cast<size_t>(k)]; };
  auto run = [&](bool late) {
    LandmarkMapConfig config;
    config.solve.rolling_shutter_sigma_rad = 0.0025;
    LandmarkMap map(config);
    addScene(&map, s, start, 0, [&](int k) { return k == 0 ? Vec3::Zero() : truth(k); });
    if (late) {
      EXPECT_TRUE(map.setRollingShutterPrior(0, truth(0)));
    }
    for (int round = 0; round < 2; ++round) EXPECT_TRUE(map.globalAdjust(0, 0).ok);
    EXPECT_FALSE(map.setRollingShutterPrior(99, Vec3::Zero())) << "no such keyframe";
    const Vec3 w5 = *map.rollingShutter(5);
    EXPECT_TRUE(map.setRollingShutterPrior(5, Vec3::Zero()));
    EXPECT_EQ(*map.rollingShutter(5), w5) << "estimated: w stays";
    EXPECT_NEAR((*map.rollingShutter(0) - (late ? truth(0) : Vec3::Zero())).norm(), 0.0, 1e-12) << "held";
    return positionRms(s.T_map_kf, posesOf(map, s.T_map_kf.size()));
  };
  const double rms_zero = run(false), rms_late = run(true);
  std::printf("[ measured ] the anchor's rolling-shutter prior at 0: rms %.5f m; set later: %.5f m\n",
              rms_zero, rms_late);
  EXPECT_LT(rms_late, 0.3 * rms_zero);
}

// A part of a global BA that no held keyframe observes (a room that only an odometry step joins
// to the rest shares no landmark with it) has no gauge in the adjustment. Its shape is refined; its placement
// as a whole is kept (else the solver's drift moved it, and a pose-graph solve pulled it back).
TEST(LandmarkMap, APartNoHeldKeyframeObservesKeepsItsPlacement) {
  BaSceneOptions o;
  o.keyframes = 12;
  const BaScene s = makeBaScene(o);
  const std::vector<SE3> start = perturbed(s, 0.02, 0.01, 14);
  constexpr int kSplit = 6;  // keyframes 0-5 (the anchor's part) and 6-11 share no landmark
  struct Run {
    BundleResult r;
    std::vector<SE3> poses;
  };
  const auto run = [&](int part_link_landmarks) {
    LandmarkMapConfig config;
    config.part_link_landmarks = part_link_landmarks;
    LandmarkMap map(config);
    addScene(&map, s, start, kSplit);
    Run out{map.globalAdjust(0, 0), {}};
    out.poses = posesOf(map, s.T_map_kf.size());
    return out;
  };
  // The free part's placement change: its mean camera centre, and the chordal mean of its rotation changes
  // (sum of R_before R_after^T is symmetric when that mean is the identity).
  const auto placementChange = [&](const std::vector<SE3>& after) {
    Vec3 shift = Vec3::Zero();
    Mat3 M = Mat3::Zero();
    for (int k = kSplit; k < o.keyframes; ++k) {
      shift += (after[k].translation() - start[k].translation()) / (o.keyframes - kSplit);
      M += start[k].linear() * after[k].linear().transpose();
    }
    return std::make_pair(shift.norm(), (M - M.transpose()).norm());
  };
  // The free part's shape: keyframe positions relative to its first, against the truth.
  const auto shapeError = [&](const std::vector<SE3>& poses) {
    double sum = 0.0;
    for (int k = kSplit + 1; k < o.keyframes; ++k) {
      const SE3 est = poses[kSplit].inverse() * poses[k],
                truth = s.T_map_kf[kSplit].inverse() * s.T_map_kf[k];
      sum += (est.translation() - truth.translation()).squaredNorm();
    }
    return std::sqrt(sum / (o.keyframes - kSplit - 1));
  };
  const Run kept = run(3), drifted = run(0);
  ASSERT_TRUE(kept.r.ok && drifted.r.ok) << kept.r.error << drifted.r.error;
  const auto [kept_m, kept_rot] = placementChange(kept.poses);
  const auto [drift_m, drift_rot] = placementChange(drifted.poses);
  std::printf(
      "[ measured ] unheld part: placement moved %.2e m (rotation asymmetry %.1e) without the correction, "
      "%.1e m (%.1e) with; shape error %.4f -> %.5f m\n",
      drift_m, drift_rot, kept_m, kept_rot, shapeError(start), shapeError(kept.poses));
  EXPECT_EQ(kept.r.parts_kept, 1);
  EXPECT_EQ(drifted.r.parts_kept, 0);
  EXPECT_LT(kept_m, 1e-9);
  EXPECT_LT(kept_rot, 1e-9);
  EXPECT_GT(drift_m + drift_rot, 1e-6) << "the solver left the part in place by itself: nothing shown";
  EXPECT_NEAR(kept.r.part_shift_m, drift_m, 0.5 * drift_m + 1e-6);
  EXPECT_LT(shapeError(kept.poses), 0.25 * shapeError(start)) << "the part's shape was not refined";
  EXPECT_TRUE(kept.poses[0].isApprox(start[0], 1e-12)) << "the anchor moved";
}

// an odometry step between two parts that share no landmark, given to the global BA as a prior,
// joins them: the part without a held keyframe is placed by it (not kept where it was), its shape refined.
TEST(LandmarkMap, APriorBetweenPartsPlacesTheUnheldOne) {
  BaSceneOptions o;
  o.keyframes = 12;
  const BaScene s = makeBaScene(o);
  const std::vector<SE3> start = perturbed(s, 0.02, 0.01, 16);
  constexpr int kSplit = 6;
  const auto run = [&](bool with_prior) {
    LandmarkMap map;
    addScene(&map, s, start, kSplit);
    std::vector<BundlePrior> priors;
    if (with_prior)  // the true step 5 -> 6, sigma 1 cm / 0.6 deg
      priors.push_back({kSplit - 1, kSplit, s.T_map_kf[kSplit - 1].inverse() * s.T_map_kf[kSplit],
                        (Vec6() << 100, 100, 100, 100, 100, 100).finished().asDiagonal()});
    const BundleResult r = map.globalAdjust(0, 0, nullptr, {}, priors);
    EXPECT_TRUE(r.ok) << r.error;
    return std::make_pair(r, positionRms(s.T_map_kf, posesOf(map, s.T_map_kf.size())));
  };
  const auto [kept, kept_rms] = run(false);
  const auto [joined, joined_rms] = run(true);
  std::printf("[ measured ] two parts: keyframe rms %.4f m kept in place, %.5f m joined by a prior\n",
              kept_rms, joined_rms);
  EXPECT_EQ(kept.parts_kept, 1);
  EXPECT_EQ(joined.parts_kept, 0) << "the prior did not join the parts";
  EXPECT_LT(joined_rms, 0.5 * kept_rms) << "the prior did not place the unheld part";
  EXPECT_LT(joined_rms, 0.005);
}

// A BundleCheck sees the outcome before it is applied and can refuse it: nothing changes then.
TEST(LandmarkMap, ARefusedAdjustmentChangesNothing) {
  BaSceneOptions o;
  o.keyframes = 12;
  const BaScene s = makeBaScene(o);
  const std::vector<SE3> start = perturbed(s, 0.02, 0.01, 15);
  LandmarkMap map;
  addScene(&map, s, start);
  const int64_t landmark = map.landmarkOf(5, 0) >= 0 ? map.landmarkOf(5, 0) : map.landmarkOf(5, 1);
  ASSERT_GE(landmark, 0);
  const Vec3 p_before = *map.positionOf(landmark);
  size_t proposed = 0;
  const BundleResult refused =
      map.globalAdjust(0, 0, nullptr, [&](const std::vector<std::pair<int64_t, SE3>>& poses) {
        proposed = poses.size();
        return std::string("refused by the test");
      });
  EXPECT_FALSE(refused.ok);
  EXPECT_TRUE(refused.refused);
  EXPECT_EQ(refused.error, "refused by the test");
  EXPECT_EQ(proposed, static_cast<size_t>(o.keyframes - 1));  // every keyframe but the anchor
  for (int k = 0; k < o.keyframes; ++k) EXPECT_TRUE(map.pose(k)->isApprox(start[k], 1e-15)) << k;
  EXPECT_EQ(*map.positionOf(landmark), p_before);
  const BundleResult accepted = map.globalAdjust(
      0, 0, nullptr, [](const std::vector<std::pair<int64_t, SE3>>&) { return std::string(); });
  EXPECT_TRUE(accepted.ok);
  EXPECT_LT(positionRms(s.T_map_kf, posesOf(map, s.T_map_kf.size())), 0.003);
}

}  // namespace
}  // namespace rgbdmap
