// Real wide-baseline Kinect frames (../shared/data/kinect_5frames_mm): the pose pipeline (brute-force
// matching, RANSAC, refinement) must be accurate where views overlap and must reject, not invent, a pose
// where they do not.
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "rgbdmap/client/odometry_config.hpp"
#include "rgbdmap/vision/pose_refiner.hpp"
#include "rgbdmap/vision/ransac.hpp"
#include "test_data.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

struct WideBaseline {
  std::vector<FrameFeatures> features;
  std::vector<SE3> T_world_cam;
};

WideBaseline load(const CameraIntrinsics& k, const OdometryConfig& config) {
  const std::string dir = testing::sharedDataDir("kinect_5frames_mm");
  WideBaseline wb;
  std::ifstream poses(dir + "/pose.txt");
  double v[7];
  while (poses >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5] >> v[6])
    wb.T_world_cam.push_back(se3::fromTum(v[0], v[1], v[2], v[3], v[4], v[5], v[6]));
  const OrbExtractor extractor(config.orb);
  for (int i = 1; i <= 5; ++i) {
    RgbdFrame f;
    f.color = cv::imread(dir + "/color/" + std::to_string(i) + ".png", cv::IMREAD_COLOR);
    f.depth = cv::imread(dir + "/depth/" + std::to_string(i) + ".pgm", cv::IMREAD_UNCHANGED);
    f.depth_scale = k.depth_scale;
    EXPECT_EQ(f.depth.type(), CV_16UC1) << "frame " << i;
    wb.features.push_back(extractor.extract(f, PinholeCamera(k)));
  }
  return wb;
}

RGBDMAP_TEST_TIER("WideBaselineReal.*", "e2e sanitize");
TEST(WideBaselineReal, AccurateWhereViewsOverlapAndRejectedWhereTheyDoNot) {
  RGBDMAP_REQUIRE_SHARED_DATA("kinect_5frames_mm");
  CameraIntrinsics k;  // the data's README: fx 518, fy 519, cx 325.5, cy 253.5, no distortion, millimetres
  k.fx = 518;
  k.fy = 519;
  k.cx = 325.5;
  k.cy = 253.5;
  k.distortion = {0, 0, 0, 0, 0};
  k.depth_scale = 1000;
  const OdometryConfig config;
  const PinholeCamera camera(k);
  const WideBaseline wb = load(k, config);
  ASSERT_EQ(wb.T_world_cam.size(), 5u);
  int accepted = 0;
  for (int i = 0; i < 5; ++i) {
    for (int j = i + 1; j < 5; ++j) {
      const FrameFeatures &ref = wb.features[i], &cur = wb.features[j];
      std::vector<char> mask(ref.size());
      for (size_t m = 0; m < mask.size(); ++m) mask[m] = ref.hasDepth(m);
      const auto matches = toPointMatches(
          cur, ref, matchDescriptors(cur.descriptors, ref.descriptors, config.matcher, &mask), 1.2f);
      const RansacResult ransac = ransacRigid(matches, camera, config.ransac);
      if (!ransac.success) continue;
      const RefineResult refined = refinePose(matches, ransac.T_cur_ref, camera, config.refine);
      const SE3 T_cur_ref_true = wb.T_world_cam[j].inverse() * wb.T_world_cam[i];
      const SE3 error = T_cur_ref_true.inverse() * refined.T_cur_ref;
      ++accepted;
      EXPECT_LT(error.translation().norm(), 0.04) << "pair " << i + 1 << "-" << j + 1;
      EXPECT_LT(se3::rotationAngle(error), 0.5 * M_PI / 180) << "pair " << i + 1 << "-" << j + 1;
    }
  }
  // Frames 4 and 5 overlap well (0.23 m apart, measured error 1.5 cm / 0.15 deg); the others barely do.
  EXPECT_GE(accepted, 1);
}

}  // namespace
}  // namespace rgbdmap
