#pragma once
// Deterministic synthetic scenes with exact ground truth, for the bundle adjustment tests and benchmarks:
// random 3-D points in front of a camera that moves sideways along a gentle arc; each keyframe sees the
// points that project into its image, with keypoints (random octave), depth and a 256-bit descriptor per
// point (a few bits flipped per view), so that matching by projection behaves as on real features.
#include <array>
#include <memory>
#include <vector>

#include "rgbdmap/ba/landmark_map.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

struct BaSynthConfig {
  int keyframes = 12;
  int points = 1500;
  double step_m = 0.08;  ///< camera motion between keyframes (along x)
  /// The arc: yaw and height gained per metre along x, roll per keyframe. Over tens of metres the default
  /// arc turns the cameras away from the points (which fill a slab at z 1.5-4 m): long scenes want ~0.
  double turn_rad_per_m = 0.04;
  double climb_per_m = 0.03;
  double roll_rad_per_keyframe = 0.005;
  double pixel_noise = 0.5;    ///< keypoint sigma, px
  double depth_noise = 0.003;  ///< sigma of 1/depth, 1/m
  int flipped_bits = 8;        ///< descriptor bits changed per view
  /// Rolling shutter: each keyframe turns by a random rotation of this angle (rad) during its readout, and
  /// its keypoints are where the rows saw them (ba_cost.hpp); 0: global shutter.
  double rolling_shutter_rad = 0.0;
  unsigned seed = 7;
};

struct BaSynthScene {
  BaIntrinsics camera;
  std::vector<Vec3> points;                          ///< map frame
  std::vector<std::array<uint8_t, 32>> descriptors;  ///< per point
  std::vector<SE3> T_map_kf;                         ///< ground truth
  std::vector<Vec3> rolling_shutter;                 ///< ground truth w per keyframe (rad)
  std::vector<std::shared_ptr<FrameFeatures>> features;
  std::vector<std::vector<int>> point_of_feature;  ///< per keyframe, per feature: the scene point
};

BaSynthScene makeBaSynthScene(const BaSynthConfig& config);
/// The true correspondences between keyframes a and b (feature index pairs).
EdgeMatches synthTrueMatches(const BaSynthScene& scene, int a, int b);
/// Keyframe k of the scene for the landmark map, at pose `T_map_kf`.
LandmarkKeyframe synthKeyframe(const BaSynthScene& scene, int k, const SE3& T_map_kf, int map_id = 0);

}  // namespace rgbdmap
