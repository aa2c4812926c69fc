#include <random>

#include <gtest/gtest.h>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {
namespace {

SE3 randomPose(std::mt19937& rng, double max_angle = 3.0, double max_t = 5.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vec6 xi;
  xi << max_t * u(rng), max_t * u(rng), max_t * u(rng), u(rng), u(rng), u(rng);
  xi.tail<3>() = xi.tail<3>().normalized() * max_angle * std::abs(u(rng));
  return se3::exp(xi);
}

TEST(Se3, ExpLogRoundTrip) {
  std::mt19937 rng(1);
  for (int i = 0; i < 200; ++i) {
    const SE3 T = randomPose(rng);
    const SE3 T2 = se3::exp(se3::log(T));
    EXPECT_LT((T.matrix() - T2.matrix()).norm(), 1e-9) << "sample " << i;
  }
}

TEST(Se3, ExpOfSmallTwistIsFirstOrder) {
  Vec6 xi;
  xi << 1e-7, -2e-7, 3e-7, 1e-9, 2e-9, -1e-9;
  const SE3 T = se3::exp(xi);
  EXPECT_NEAR(T.translation().x(), 1e-7, 1e-14);
  EXPECT_NEAR(se3::log(T)(4), 2e-9, 1e-15);
}

TEST(Se3, HandComputedRotation) {
  Vec6 xi = Vec6::Zero();
  xi(5) = M_PI / 2;  // 90 degrees about z
  const SE3 T = se3::exp(xi);
  EXPECT_TRUE((T.linear() * Vec3::UnitX()).isApprox(Vec3::UnitY(), 1e-12));
  EXPECT_NEAR(se3::rotationAngle(T), M_PI / 2, 1e-12);
}

TEST(Se3, TumQuaternionOrderAndInverse) {
  // TUM order is qx qy qz qw: a 180 degree rotation about x.
  const SE3 T = se3::fromTum(1, 2, 3, 1, 0, 0, 0);
  EXPECT_TRUE((T * Vec3(0, 1, 0)).isApprox(Vec3(1, 1, 3), 1e-12));
  const SE3 I = T * T.inverse();
  EXPECT_TRUE(I.matrix().isIdentity(1e-12));
  EXPECT_GE(se3::quat(T).w(), 0.0);
}

TEST(Se3, InterpolateEndpointsAndMidpoint) {
  std::mt19937 rng(2);
  const SE3 a = randomPose(rng, 1.0), b = randomPose(rng, 1.0);
  EXPECT_TRUE(se3::interpolate(a, b, 0.0).isApprox(a, 1e-9));
  EXPECT_TRUE(se3::interpolate(a, b, 1.0).isApprox(b, 1e-9));
  const SE3 m = se3::interpolate(a, b, 0.5);
  // The midpoint is equally far (in rotation) from both ends.
  EXPECT_NEAR(se3::rotationAngle(a.inverse() * m), se3::rotationAngle(m.inverse() * b), 1e-9);
  EXPECT_TRUE(m.translation().isApprox(0.5 * (a.translation() + b.translation()), 1e-12));
}

TEST(Se3, ValidityAndNormalisation) {
  SE3 T = SE3::Identity();
  EXPECT_TRUE(se3::isValid(T));
  T.linear()(0, 0) = 1.001;
  EXPECT_FALSE(se3::isValid(T));
  EXPECT_TRUE(se3::isValid(se3::normalized(T)));
  T.translation().x() = std::nan("");
  EXPECT_FALSE(se3::isValid(T));
}

TEST(Se3, EulerRPYMatchesComposition) {
  const double roll = 0.3, pitch = -0.2, yaw = 1.1;
  const Mat3 R = (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch, Vec3::UnitY()) *
                  Eigen::AngleAxisd(roll, Vec3::UnitX()))
                     .toRotationMatrix();
  const Vec3 rpy = se3::eulerRPY(R);
  EXPECT_NEAR(rpy.x(), roll, 1e-12);
  EXPECT_NEAR(rpy.y(), pitch, 1e-12);
  EXPECT_NEAR(rpy.z(), yaw, 1e-12);
}

}  // namespace
}  // namespace rgbdmap
