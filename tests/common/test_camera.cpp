#include <random>

#include <gtest/gtest.h>

#include "rgbdmap/common/camera.hpp"

namespace rgbdmap {
namespace {

TEST(Camera, ProjectBackProjectRoundTripIdeal) {
  CameraIntrinsics k;
  k.distortion = {0, 0, 0, 0, 0};
  const PinholeCamera cam(k);
  const Eigen::Vector3d p(0.3, -0.2, 2.0);
  const auto px = cam.project(p);
  ASSERT_TRUE(px);
  // Hand-computed: u = 517.3 * 0.15 + 318.6, v = 516.5 * -0.1 + 255.3
  EXPECT_NEAR(px->x(), 396.195, 1e-9);
  EXPECT_NEAR(px->y(), 203.65, 1e-9);
  EXPECT_TRUE(cam.backProject(*px, 2.0).isApprox(p, 1e-12));
  EXPECT_FALSE(cam.project(Eigen::Vector3d(0, 0, -1)));
}

TEST(Camera, UndistortInvertsDistortWithTumCoefficients) {
  const PinholeCamera cam{CameraIntrinsics{}};  // TUM fr1 defaults with distortion
  ASSERT_TRUE(cam.intrinsics().hasDistortion());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(20.0, 620.0), v(20.0, 460.0);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector2d ideal(u(rng), v(rng));
    const Eigen::Vector2d raw = cam.distort(ideal);
    EXPECT_LT((cam.undistort(raw) - ideal).norm(), 1e-6) << ideal.transpose();
  }
}

TEST(Camera, DistortionMovesCornersNotCentre) {
  const PinholeCamera cam{CameraIntrinsics{}};
  const Eigen::Vector2d centre(cam.intrinsics().cx, cam.intrinsics().cy);
  EXPECT_LT((cam.distort(centre) - centre).norm(), 1e-12);
  EXPECT_GT((cam.distort({5.0, 5.0}) - Eigen::Vector2d(5.0, 5.0)).norm(), 1.0);
}

TEST(Camera, ProjectDistortedThenBackProjectRaw) {
  const PinholeCamera cam{CameraIntrinsics{}};
  const Eigen::Vector3d p(-0.5, 0.4, 1.7);
  const auto raw = cam.projectDistorted(p);
  ASSERT_TRUE(raw);
  EXPECT_LT((cam.backProjectRaw(*raw, 1.7) - p).norm(), 1e-6);
}

TEST(Camera, ValidateReportsBadValues) {
  CameraIntrinsics k;
  EXPECT_EQ(k.validate(), "");
  k.fx = -1;
  k.depth_scale = std::nan("");
  const std::string err = k.validate();
  EXPECT_NE(err.find("fx = -1 is outside [1, 100000]"), std::string::npos) << err;
  EXPECT_NE(err.find("depth_scale"), std::string::npos);
}

TEST(Camera, InImageBorder) {
  const PinholeCamera cam{CameraIntrinsics{}};
  EXPECT_TRUE(cam.inImage({0, 0}));
  EXPECT_FALSE(cam.inImage({0, 0}, 1.0));
  EXPECT_FALSE(cam.inImage({640, 10}));
}

}  // namespace
}  // namespace rgbdmap
