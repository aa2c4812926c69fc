// sensor_msgs/Image and CameraInfo: round trips, every truncation and forged lengths rejected, the depth and
// colour conversions (32FC1 exact for every raw value, 16UC1, big-endian, unsupported encodings).
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "rgbdmap/source/ros_messages.hpp"

namespace rgbdmap {
namespace {

cv::Mat rosTestColor() {
  cv::Mat bgr(3, 4, CV_8UC3);
  cv::randu(bgr, 0, 255);
  return bgr;
}

TEST(RosMessages, ImageRoundTripsAndEveryTruncationFails) {
  const cv::Mat bgr = rosTestColor();
  const ros1::Image image = ros1::imageFromMat(bgr, "rgb8", 1305031102.175304);
  const std::vector<uint8_t> bytes = ros1::encodeImage(image);
  auto back = ros1::decodeImage(bytes.data(), bytes.size());
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back->encoding, "rgb8");
  EXPECT_EQ(back->header.stamp_sec, 1305031102u);
  EXPECT_NEAR(back->header.stamp_nsec, 175304000.0, 500.0);  // a double holds ~0.24 us at this epoch
  auto color = ros1::colorFromImage(*back);
  ASSERT_TRUE(color) << color.error();
  EXPECT_EQ(cv::norm(*color, bgr, cv::NORM_INF), 0.0);  // rgb8 turned back into BGR
  for (size_t n = 0; n < bytes.size(); ++n) EXPECT_FALSE(ros1::decodeImage(bytes.data(), n)) << n;
}

TEST(RosMessages, ForgedLengthsAndStepsAreRejected) {
  ros1::Image image = ros1::imageFromMat(rosTestColor(), "bgr8", 1.0);
  std::vector<uint8_t> bytes = ros1::encodeImage(image);
  const size_t data_len_at = bytes.size() - image.data.size() - 4;
  const uint32_t huge = 0xFFFFFFF0u;
  std::memcpy(bytes.data() + data_len_at, &huge, 4);
  EXPECT_FALSE(ros1::decodeImage(bytes.data(), bytes.size()));
  image.step = 1000;  // rows longer than the data
  const std::vector<uint8_t> bad_step = ros1::encodeImage(image);
  EXPECT_FALSE(ros1::decodeImage(bad_step.data(), bad_step.size()));
  image.step = 2;  // rows shorter than the pixels
  image.data.resize(2 * image.height);
  EXPECT_FALSE(ros1::colorFromImage(image));
}

TEST(RosMessages, Depth32FC1IsExactForEveryRawValue) {
  cv::Mat raw(256, 256, CV_16UC1);  // every value 0..65535 once
  for (int i = 0; i < 65536; ++i) raw.at<uint16_t>(i / 256, i % 256) = static_cast<uint16_t>(i);
  cv::Mat metres;
  raw.convertTo(metres, CV_32FC1, 1.0 / 5000.0);
  metres.at<float>(0, 0) = std::nanf("");  // no measurement in a TUM bag
  metres.at<float>(0, 1) = -1.0f;
  double scale = 0;
  auto depth = ros1::depthFromImage(ros1::imageFromMat(metres, "32FC1", 1.0), &scale);
  ASSERT_TRUE(depth) << depth.error();
  EXPECT_EQ(scale, 5000.0);
  EXPECT_EQ(depth->at<uint16_t>(0, 0), 0);
  EXPECT_EQ(depth->at<uint16_t>(0, 1), 0);
  int mismatches = 0;
  for (int i = 2; i < 65536; ++i)
    mismatches += depth->at<uint16_t>(i / 256, i % 256) != raw.at<uint16_t>(i / 256, i % 256);
  EXPECT_EQ(mismatches, 0);
}

TEST(RosMessages, Depth16UC1MillimetresAndByteOrder) {
  cv::Mat mm(2, 3, CV_16UC1);
  for (int i = 0; i < 6; ++i) mm.at<uint16_t>(i / 3, i % 3) = static_cast<uint16_t>(300 + 1000 * i);
  ros1::Image image = ros1::imageFromMat(mm, "16UC1", 1.0);
  double scale = 0;
  auto depth = ros1::depthFromImage(image, &scale);
  ASSERT_TRUE(depth);
  EXPECT_EQ(scale, 1000.0);
  EXPECT_EQ(cv::norm(*depth, mm, cv::NORM_INF), 0.0);
  image.is_bigendian = !image.is_bigendian;
  for (size_t i = 0; i + 1 < image.data.size(); i += 2) std::swap(image.data[i], image.data[i + 1]);
  auto swapped = ros1::depthFromImage(image, &scale);
  ASSERT_TRUE(swapped);
  EXPECT_EQ(cv::norm(*swapped, mm, cv::NORM_INF), 0.0);
}

TEST(RosMessages, UnsupportedEncodingsNameThemselves) {
  double scale = 0;
  const ros1::Image color = ros1::imageFromMat(rosTestColor(), "rgb8", 1.0);
  const auto as_depth = ros1::depthFromImage(color, &scale);
  ASSERT_FALSE(as_depth);
  EXPECT_NE(as_depth.error().find("unsupported depth encoding 'rgb8'"), std::string::npos)
      << as_depth.error();
  ros1::Image yuv = color;
  yuv.encoding = "yuv422";
  const auto as_color = ros1::colorFromImage(yuv);
  ASSERT_FALSE(as_color);
  EXPECT_NE(as_color.error().find("unsupported colour encoding 'yuv422'"), std::string::npos);
  cv::Mat grey(3, 4, CV_8UC1, cv::Scalar(7));
  auto mono = ros1::colorFromImage(ros1::imageFromMat(grey, "mono8", 1.0));
  ASSERT_TRUE(mono);
  EXPECT_EQ(mono->type(), CV_8UC3);
  EXPECT_EQ(mono->at<cv::Vec3b>(1, 1), cv::Vec3b(7, 7, 7));
}

TEST(RosMessages, CameraInfoGivesTheIntrinsics) {
  ros1::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info.distortion_model = "plumb_bob";
  info.D = {0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  info.K = {517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1};
  const std::vector<uint8_t> bytes = ros1::encodeCameraInfo(info);
  auto back = ros1::decodeCameraInfo(bytes.data(), bytes.size());
  ASSERT_TRUE(back) << back.error();
  auto camera = ros1::cameraFromInfo(*back);
  ASSERT_TRUE(camera) << camera.error();
  EXPECT_EQ(camera->fx, 517.3);
  EXPECT_EQ(camera->fy, 516.5);
  EXPECT_EQ(camera->cx, 318.6);
  EXPECT_EQ(camera->cy, 255.3);
  EXPECT_EQ(camera->width, 640);
  EXPECT_EQ(camera->distortion[4], 1.1633);
  for (size_t n = 0; n + 25 < bytes.size(); ++n)  // binning and roi (25 bytes) are not read
    EXPECT_FALSE(ros1::decodeCameraInfo(bytes.data(), n)) << n;
  info.K[0] = 0;  // fx 0: not a camera
  const std::vector<uint8_t> zero = ros1::encodeCameraInfo(info);
  EXPECT_FALSE(ros1::cameraFromInfo(*ros1::decodeCameraInfo(zero.data(), zero.size())));
}

}  // namespace
}  // namespace rgbdmap
