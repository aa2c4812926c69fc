// 7scenes:DIR: depth registered to the colour camera, pose files parsed strictly, the colour camera's
// ground truth, unreadable frames and bad poses counted rather than fatal.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "common/temp_dir.hpp"
#include "rgbdmap/source/frame_source.hpp"
#include "rgbdmap/source/seven_scenes.hpp"

namespace rgbdmap {
namespace {

using testing::TempDir;

const char* kIdentityPose = "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";

/// A plane at `z_mm` in front of the depth camera, with one "no measurement" pixel.
cv::Mat planeDepth(uint16_t z_mm) {
  cv::Mat depth(480, 640, CV_16UC1, cv::Scalar(z_mm));
  depth.at<uint16_t>(240, 320) = 65535;
  return depth;
}

TEST(SevenScenes, RegistrationWithoutMotionAndEqualCamerasIsTheIdentity) {
  const SevenScenesCalibration cal = SevenScenesCalibration::standard();
  cv::Mat depth = planeDepth(2000);
  depth.at<uint16_t>(10, 10) = 0;
  const cv::Mat out = registerDepth(depth, cal.depth_camera, cal.depth_camera, SE3::Identity(), 65535);
  EXPECT_EQ(out.at<uint16_t>(100, 100), 2000);
  EXPECT_EQ(out.at<uint16_t>(240, 320), 0) << "65535 is no measurement";
  EXPECT_EQ(out.at<uint16_t>(10, 10), 0);
  EXPECT_EQ(cv::countNonZero(out), 640 * 480 - 2);
}

TEST(SevenScenes, RegistrationMovesAPlaneByTheBaselineAndTheFocalRatio) {
  const SevenScenesCalibration cal = SevenScenesCalibration::standard();
  const cv::Mat out =
      registerDepth(planeDepth(2000), cal.depth_camera, cal.colour_camera, cal.T_colour_depth, 65535);
  // The depth camera's image (focal 585) covers less than the colour camera's (525) sees: the colour
  // image's border has no depth, its centre has, at about 2 m (the cameras are nearly parallel).
  EXPECT_EQ(out.at<uint16_t>(240, 2), 0);
  EXPECT_EQ(out.at<uint16_t>(240, 637), 0);
  EXPECT_NEAR(out.at<uint16_t>(240, 300), 2000, 25);
  // A point on the depth camera's optical axis at 2 m lands at the colour camera's projection of it.
  const Vec3 p = cal.T_colour_depth * Vec3(0, 0, 2.0);
  const long x = std::lround(525.0 * p.x() / p.z() + 319.5), y = std::lround(525.0 * p.y() / p.z() + 239.5);
  EXPECT_LT(x, 319) << "the depth camera's axis lands left of the colour image's centre (2.6 cm baseline)";
  EXPECT_NEAR(out.at<uint16_t>(static_cast<int>(y), static_cast<int>(x)), std::lround(p.z() * 1000), 1);
}

TEST(SevenScenes, PoseFilesAreParsedStrictly) {
  auto ok = parseSevenScenesPose("0 -1 0 0.5\t\n1 0 0 1\t\n0 0 1 -2\t\n0 0 0 1\t\n", "p.txt");
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_NEAR(ok->translation().z(), -2.0, 1e-12);
  EXPECT_NEAR((ok->linear() * Vec3::UnitX() - Vec3::UnitY()).norm(), 0.0, 1e-12);
  for (const char* bad : {"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 7",
                          "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 nan", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 x",
                          "2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1", "1 0 0 0 0 1 0 0 0 0 -1 0 0 0 0 1",
                          "1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1", ""}) {
    auto r = parseSevenScenesPose(bad, "bad.txt");
    EXPECT_FALSE(r) << bad;
    if (!r) {
      EXPECT_EQ(r.error().rfind("bad.txt: ", 0), 0u) << r.error();
    }
  }
}

class SevenScenesFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int i = 0; i < 3; ++i) {
      const std::string base = dir_.path("frame-00000" + std::to_string(i) + ".");
      cv::imwrite(base + "color.png", cv::Mat(480, 640, CV_8UC3, cv::Scalar(30 * i, 60, 90)));
      if (i != 1) cv::imwrite(base + "depth.png", planeDepth(1500));
      dir_.write("frame-00000" + std::to_string(i) + ".pose.txt", i == 2 ? "1 2 3" : kIdentityPose);
    }
  }
  TempDir dir_;
};

TEST_F(SevenScenesFolder, IsRecognisedAndReadFrameByFrame) {
  EXPECT_TRUE(isSevenScenesFolder(dir_.dir()));
  auto url = SourceUrl::parse("7scenes:" + dir_.dir());
  ASSERT_TRUE(url) << url.error();
  auto source = openFrameSource(*url, SourceOptions{});
  ASSERT_TRUE(source) << source.error();
  FrameSource& s = **source;
  EXPECT_EQ(s.sizeHint(), 3u);
  ASSERT_TRUE(s.camera());
  EXPECT_EQ(s.camera()->fx, 525.0);
  EXPECT_EQ(s.camera()->depth_scale, 1000.0);
  EXPECT_FALSE(s.camera()->hasDistortion());
  ASSERT_TRUE(s.groundTruth());
  ASSERT_EQ(s.groundTruth()->size(), 2u) << "the malformed third pose is left out";
  // The colour camera's pose: the identity depth-camera pose times T_depth_colour.
  const SE3 expected = SevenScenesCalibration::standard().T_colour_depth.inverse();
  EXPECT_NEAR((s.groundTruth()->at(1).T_world_cam.translation() - expected.translation()).norm(), 0, 1e-9);
  EXPECT_NEAR(s.groundTruth()->at(1).timestamp, 1.0 / 30.0, 1e-12);

  FrameRead first = s.next();
  ASSERT_EQ(first.kind, FrameRead::Kind::kFrame) << first.error;
  EXPECT_EQ(first.frame.depth.type(), CV_16UC1);
  EXPECT_EQ(first.frame.depth_scale, 1000.0);
  EXPECT_NEAR(first.frame.depth.at<uint16_t>(240, 300), 1500, 20);
  FrameRead second = s.next();
  EXPECT_EQ(second.kind, FrameRead::Kind::kUnreadable);
  EXPECT_NE(second.error.find("frame-000001.depth.png"), std::string::npos) << second.error;
  EXPECT_EQ(s.next().kind, FrameRead::Kind::kFrame);
  EXPECT_EQ(s.next().kind, FrameRead::Kind::kEnd);
}

TEST_F(SevenScenesFolder, HonoursTheFrameRange) {
  auto url = SourceUrl::parse("7scenes:" + dir_.dir());
  ASSERT_TRUE(url);
  SourceOptions o;
  o.first_frame = 2;
  auto source = openFrameSource(*url, o);
  ASSERT_TRUE(source) << source.error();
  FrameRead r = (*source)->next();
  EXPECT_EQ(r.index, 2u);
  EXPECT_EQ((*source)->next().kind, FrameRead::Kind::kEnd);
}

TEST(SevenScenes, AFolderWithoutFramesOrWithRgbTxtIsNotOne) {
  TempDir dir;
  EXPECT_FALSE(isSevenScenesFolder(dir.dir()));
  auto url = SourceUrl::parse("7scenes:" + dir.dir());
  ASSERT_TRUE(url);
  auto source = openFrameSource(*url, SourceOptions{});
  ASSERT_FALSE(source);
  EXPECT_NE(source.error().find("no frame-000000.color.png"), std::string::npos) << source.error();
  cv::imwrite(dir.path("frame-000000.color.png"), cv::Mat(480, 640, CV_8UC3, cv::Scalar(1, 2, 3)));
  EXPECT_TRUE(isSevenScenesFolder(dir.dir()));
  dir.write("rgb.txt", "# a TUM folder\n");
  EXPECT_FALSE(isSevenScenesFolder(dir.dir()));
  EXPECT_FALSE(openFrameSource(*SourceUrl::parse("7scenes:" + dir.path("missing")), SourceOptions{}));
}

}  // namespace
}  // namespace rgbdmap
