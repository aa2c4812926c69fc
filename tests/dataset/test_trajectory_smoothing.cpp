#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "rgbdmap/dataset/trajectory_smoothing.hpp"

namespace rgbdmap {
namespace {

/// Camera centre quadratic in time, rotation at a constant rate about one axis: a quadratic fit keeps both.
SE3 smoothMotion(double t) {
  SE3 T = SE3::Identity();
  T.linear() = se3::expSO3(Vec3(0.3, -0.5, 0.8) * t);
  T.translation() = Vec3(0.2, -0.1, 1.0) + Vec3(0.25, 0.1, -0.05) * t + Vec3(-0.3, 0.2, 0.1) * t * t;
  return T;
}

/// 30 frames/s with up to 4 ms of jitter in the stamps, as a camera driver's.
Trajectory truth(int n, uint32_t seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.004, 0.004);
  Trajectory out;
  for (int i = 0; i < n; ++i) {
    const double t = i / 30.0 + jitter(rng);
    out.push_back({t, smoothMotion(t)});
  }
  return out;
}

double positionRms(const Trajectory& a, const Trajectory& b) {
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i)
    sum += (a[i].T_world_cam.translation() - b[i].T_world_cam.translation()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(a.size()));
}

double rotationRms(const Trajectory& a, const Trajectory& b) {
  double sum = 0.0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double angle = se3::rotationAngle(a[i].T_world_cam.inverse() * b[i].T_world_cam);
    sum += angle * angle;
  }
  return std::sqrt(sum / static_cast<double>(a.size()));
}

TEST(TrajectorySmoothing, SmoothMotionIsKeptExactly) {
  const Trajectory gt = truth(120);
  const Trajectory out = smoothTrajectory(gt, {}, 0.3);
  ASSERT_EQ(out.size(), gt.size());
  EXPECT_LT(positionRms(out, gt), 1e-9);
  EXPECT_LT(rotationRms(out, gt), 1e-9);
  for (size_t i = 0; i < gt.size(); ++i) EXPECT_EQ(out[i].timestamp, gt[i].timestamp);
}

TEST(TrajectorySmoothing, PerFrameNoiseShrinks) {
  const Trajectory gt = truth(300);
  std::mt19937 rng(7);
  std::normal_distribution<double> position(0.0, 0.003), rotation(0.0, 0.005);
  Trajectory noisy = gt;
  for (StampedPose& p : noisy) {
    p.T_world_cam.translation() += Vec3(position(rng), position(rng), position(rng));
    p.T_world_cam.linear() =
        p.T_world_cam.linear() * se3::expSO3(Vec3(rotation(rng), rotation(rng), rotation(rng)));
  }
  const Trajectory out = smoothTrajectory(noisy, {}, 0.3);
  const double before = positionRms(noisy, gt), after = positionRms(out, gt);
  const double rot_before = rotationRms(noisy, gt), rot_after = rotationRms(out, gt);
  std::printf(
      "[ measured ] noise 3 mm / 0.005 rad per axis: position rms %.2f -> %.2f mm, rotation %.4f -> "
      "%.4f rad\n",
      1e3 * before, 1e3 * after, rot_before, rot_after);
  // A quadratic over ~19 frames keeps about 0.35 of white noise in the middle, more at the ends.
  EXPECT_LT(after, 0.5 * before);
  EXPECT_LT(rot_after, 0.5 * rot_before);
}

TEST(TrajectorySmoothing, NoFitCrossesASegment) {
  Trajectory poses;
  std::vector<SmoothingInput> inputs;
  for (int i = 0; i < 60; ++i) {
    SE3 T = SE3::Identity();
    T.translation() = Vec3(i < 30 ? 0.0 : 1.0, 0.0, 0.0);  // a new segment starts 1 m away
    poses.push_back({i / 30.0, T});
    inputs.push_back({i < 30 ? 0 : 1, true});
  }
  const Trajectory split = smoothTrajectory(poses, inputs, 0.3);
  EXPECT_LT(positionRms(split, poses), 1e-12);
  const Trajectory joined = smoothTrajectory(poses, {}, 0.3);  // one segment: the jump is smeared
  EXPECT_GT((joined[29].T_world_cam.translation() - poses[29].T_world_cam.translation()).norm(), 0.05);
}

TEST(TrajectorySmoothing, AnUnusablePoseIsKeptAndNotFitted) {
  const Trajectory gt = truth(60);
  Trajectory poses = gt;
  std::vector<SmoothingInput> inputs(poses.size());
  poses[30].T_world_cam.translation() += Vec3(0.5, 0.0, 0.0);  // a lost frame's held prediction
  inputs[30].usable = false;
  const Trajectory out = smoothTrajectory(poses, inputs, 0.3);
  EXPECT_LT((out[30].T_world_cam.matrix() - poses[30].T_world_cam.matrix()).norm(), 1e-15);
  Trajectory others = out, others_gt = gt;
  others.erase(others.begin() + 30);
  others_gt.erase(others_gt.begin() + 30);
  EXPECT_LT(positionRms(others, others_gt), 1e-9);
}

TEST(TrajectorySmoothing, OrderOfTheInputDoesNotMatter) {
  const Trajectory gt = truth(90, 3);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.002);
  Trajectory noisy = gt;
  for (StampedPose& p : noisy) p.T_world_cam.translation() += Vec3(noise(rng), noise(rng), noise(rng));
  Trajectory shuffled = noisy;
  std::reverse(shuffled.begin(), shuffled.end());
  const Trajectory a = smoothTrajectory(noisy, {}, 0.3);
  Trajectory b = smoothTrajectory(shuffled, {}, 0.3);
  std::reverse(b.begin(), b.end());
  EXPECT_LT(positionRms(a, b), 1e-12);
}

TEST(TrajectorySmoothing, DegenerateInputsStayFinite) {
  const Trajectory gt = truth(10);
  EXPECT_LT(positionRms(smoothTrajectory(gt, {}, 0.0), gt), 1e-15);  // off
  const Trajectory one(gt.begin(), gt.begin() + 1);
  EXPECT_LT(positionRms(smoothTrajectory(one, {}, 0.3), one), 1e-15);
  Trajectory same_time = gt;  // every stamp equal: the mean pose, finite
  for (StampedPose& p : same_time) p.timestamp = 1.0;
  for (const StampedPose& p : smoothTrajectory(same_time, {}, 0.3))
    EXPECT_TRUE(se3::isValid(p.T_world_cam, 1e-6));
  Trajectory two(gt.begin(), gt.begin() + 2);  // a line through two poses passes through both
  EXPECT_LT(positionRms(smoothTrajectory(two, {}, 0.3), two), 1e-9);
}

TEST(TrajectorySmoothing, NonFiniteInputNeitherSpreadsNorCrashes) {
  const Trajectory gt = truth(40);
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.003);
  Trajectory poses = gt;
  for (StampedPose& p : poses) p.T_world_cam.translation() += Vec3(noise(rng), noise(rng), noise(rng));
  poses[20].T_world_cam.translation().x() = std::numeric_limits<double>::quiet_NaN();
  const Trajectory out = smoothTrajectory(poses, {}, 0.3);
  // Its neighbours are smoothed without it (a NaN in their fits would leave them as they were).
  Trajectory near_in(poses.begin() + 12, poses.begin() + 20), near_out(out.begin() + 12, out.begin() + 20),
      near_gt(gt.begin() + 12, gt.begin() + 20);
  EXPECT_LT(positionRms(near_out, near_gt), 0.7 * positionRms(near_in, near_gt));
  Trajectory bad_stamp = gt;
  bad_stamp[5].timestamp = std::numeric_limits<double>::infinity();
  EXPECT_LT(positionRms(smoothTrajectory(bad_stamp, {}, 0.3), bad_stamp), 1e-15);
}

/// A lost stretch: frames [first, last] replaced by a held prediction that runs away (constant velocity
/// from the last tracked frame plus a growing error), marked unusable.
std::vector<SmoothingInput> loseFrames(Trajectory* poses, size_t first, size_t last) {
  std::vector<SmoothingInput> inputs(poses->size());
  for (size_t i = first; i <= last; ++i) {
    (*poses)[i].T_world_cam.translation() += Vec3(0.02, -0.01, 0.015) * static_cast<double>(i - first + 1);
    inputs[i].usable = false;
  }
  return inputs;
}

TEST(TrajectoryBridging, ALostStretchIsInterpolatedBetweenTheTrackedFramesAroundIt) {
  const Trajectory gt = truth(90);
  Trajectory poses = gt;
  const std::vector<SmoothingInput> inputs = loseFrames(&poses, 40, 49);
  const Trajectory out = bridgeUnusable(poses, inputs);
  for (size_t i = 0; i < gt.size(); ++i) {
    if (i >= 40 && i <= 49) continue;
    EXPECT_LT((out[i].T_world_cam.matrix() - poses[i].T_world_cam.matrix()).norm(), 1e-15) << i;
  }
  const double span = gt[50].timestamp - gt[39].timestamp;
  for (size_t i = 40; i <= 49; ++i) {
    const SE3 expected =
        se3::interpolate(gt[39].T_world_cam, gt[50].T_world_cam, (gt[i].timestamp - gt[39].timestamp) / span);
    EXPECT_LT((out[i].T_world_cam.matrix() - expected.matrix()).norm(), 1e-9) << i;
  }
  const Trajectory lost_in(poses.begin() + 40, poses.begin() + 50),
      lost_out(out.begin() + 40, out.begin() + 50), lost_gt(gt.begin() + 40, gt.begin() + 50);
  std::printf("[ measured ] 10 lost frames: position rms %.1f -> %.1f mm\n",
              1e3 * positionRms(lost_in, lost_gt), 1e3 * positionRms(lost_out, lost_gt));
  EXPECT_LT(positionRms(lost_out, lost_gt), 0.1 * positionRms(lost_in, lost_gt));
}

TEST(TrajectoryBridging, OpenEndsStayAndSegmentsAreCrossed) {
  const Trajectory gt = truth(60);
  Trajectory poses = gt;
  std::vector<SmoothingInput> inputs = loseFrames(&poses, 0, 4);  // lost before the first tracked frame
  const auto end_lost = loseFrames(&poses, 55, 59);               // and after the last
  for (size_t i = 55; i < 60; ++i) inputs[i] = end_lost[i];
  const auto middle = loseFrames(&poses, 20, 29);
  for (size_t i = 20; i < 30; ++i) inputs[i] = middle[i];
  for (size_t i = 30; i < 60; ++i) inputs[i].segment = 1;  // tracking came back in a new segment
  const Trajectory out = bridgeUnusable(poses, inputs);
  for (size_t i : {0, 4, 55, 59})
    EXPECT_LT((out[i].T_world_cam.matrix() - poses[i].T_world_cam.matrix()).norm(), 1e-15) << i;
  const Trajectory lost_out(out.begin() + 20, out.begin() + 30), lost_gt(gt.begin() + 20, gt.begin() + 30);
  EXPECT_LT(positionRms(lost_out, lost_gt), 0.01);
}

TEST(TrajectoryBridging, OrderNonFiniteAndMismatchedInputs) {
  const Trajectory gt = truth(50, 9);
  Trajectory poses = gt;
  std::vector<SmoothingInput> inputs = loseFrames(&poses, 20, 24);
  poses[22].T_world_cam.translation().x() = std::numeric_limits<double>::quiet_NaN();  // a NaN held pose
  poses[30].T_world_cam.translation().y() = std::numeric_limits<double>::infinity();   // a NaN "tracked" one
  const Trajectory out = bridgeUnusable(poses, inputs);
  for (const StampedPose& p : out) EXPECT_TRUE(p.T_world_cam.matrix().allFinite());
  Trajectory reversed = poses;
  std::vector<SmoothingInput> reversed_inputs = inputs;
  std::reverse(reversed.begin(), reversed.end());
  std::reverse(reversed_inputs.begin(), reversed_inputs.end());
  Trajectory back = bridgeUnusable(reversed, reversed_inputs);
  std::reverse(back.begin(), back.end());
  EXPECT_LT(positionRms(back, out), 1e-12);
  EXPECT_LT(positionRms(bridgeUnusable(gt, {}), gt), 1e-15);  // inputs not parallel: unchanged
  Trajectory bad_stamp = poses;
  bad_stamp[3].timestamp = std::numeric_limits<double>::quiet_NaN();
  const Trajectory kept = bridgeUnusable(bad_stamp, inputs);
  EXPECT_TRUE(std::isnan(kept[22].T_world_cam.translation().x()));
}

}  // namespace
}  // namespace rgbdmap
