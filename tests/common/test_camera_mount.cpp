// The camera mount: T_base_camera from xyz + roll/pitch/yaw of a body-convention camera frame, its checks
// and its config keys.
#include <gtest/gtest.h>

#include <cmath>

#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/common/common_config_tables.hpp"
#include "rgbdmap/common/config_reader.hpp"

namespace rgbdmap {
namespace {

TEST(CameraMount, DefaultIsALevelForwardCamera) {
  const SE3 T = CameraMount{}.T_base_camera();
  EXPECT_TRUE(T.isApprox(defaultT_base_camera()));
  const Mat3 R = T.linear();
  EXPECT_TRUE(R.col(2).isApprox(Vec3::UnitX(), 1e-12)) << "camera z (forward) = base x";
  EXPECT_TRUE(R.col(0).isApprox(-Vec3::UnitY(), 1e-12)) << "camera x (right) = base -y";
  EXPECT_TRUE(R.col(1).isApprox(-Vec3::UnitZ(), 1e-12)) << "camera y (down) = base -z";
  EXPECT_TRUE(T.translation().isZero());
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(R_body_optical().isApprox(R, 1e-12));
}

TEST(CameraMount, OffsetAndTiltAreInTheBaseFrame) {
  CameraMount m;
  m.xyz_m = {0.2, 0.0, 0.45};
  m.rpy_deg = {0.0, 30.0, 0.0};  // pitched 30 degrees down
  const SE3 T = m.T_base_camera();
  EXPECT_TRUE(T.translation().isApprox(Vec3(0.2, 0.0, 0.45), 1e-12));
  const Vec3 forward = T.linear().col(2);
  EXPECT_NEAR(forward.x(), std::cos(M_PI / 6), 1e-12);
  EXPECT_NEAR(forward.z(), -std::sin(M_PI / 6), 1e-12) << "pitch > 0 looks down";
  EXPECT_NEAR(forward.y(), 0.0, 1e-12);
  m.rpy_deg = {0.0, 0.0, 90.0};  // looking left
  EXPECT_TRUE(m.T_base_camera().linear().col(2).isApprox(Vec3::UnitY(), 1e-12));
  m.rpy_deg = {90.0, 0.0,
               0.0};  // rolled +90 degrees about the optical axis (base x): image right = base down
  EXPECT_TRUE(m.T_base_camera().linear().col(0).isApprox(-Vec3::UnitZ(), 1e-12));
  EXPECT_TRUE(m.T_base_camera().linear().col(2).isApprox(Vec3::UnitX(), 1e-12));
}

TEST(CameraMount, ChecksAndConfigKeys) {
  EXPECT_EQ(CameraMount{}.validate(), "");
  CameraMount far;
  far.xyz_m = {0.0, 0.0, kMaxCameraOffsetM + 1.0};
  EXPECT_NE(far.validate().find("xyz_m"), std::string::npos);
  CameraMount spun;
  spun.rpy_deg = {0.0, 400.0, 0.0};
  EXPECT_NE(spun.validate().find("rpy_deg"), std::string::npos);
  CameraMount nan;
  nan.xyz_m[1] = std::nan("");
  EXPECT_FALSE(nan.validate().empty());

  auto reader = ConfigReader::fromString("mount:\n  xyz_m: [0.1, 0, 0.3]\n  rpy_deg: [0, 5, 0]\n");
  ASSERT_TRUE(reader) << reader.error();
  CameraMount read;
  cameraMountConfigTable().read(*reader, &read, "mount.");
  EXPECT_TRUE(reader->errors().empty());
  EXPECT_EQ(read.xyz_m[2], 0.3);
  EXPECT_EQ(read.rpy_deg[1], 5.0);
  auto bad = ConfigReader::fromString("mount:\n  xyz_m: [0.1, 0]\n");
  ASSERT_TRUE(bad) << bad.error();
  cameraMountConfigTable().read(*bad, &read, "mount.");
  EXPECT_FALSE(bad->errors().empty()) << "a list of two numbers is refused";
}

}  // namespace
}  // namespace rgbdmap
