// sensor_msgs/msg/Image and CameraInfo in CDR: round trips, the exact little-endian layout, big-endian
// encapsulation, every truncation and forged lengths rejected.
#include <algorithm>
#include <cstring>

#include <gtest/gtest.h>

#include "rgbdmap/source/ros2_messages.hpp"

namespace rgbdmap {
namespace {

TEST(Ros2Messages, ImageRoundTripsWithTheCdrLayoutAndEveryTruncationFails) {
  cv::Mat bgr(3, 4, CV_8UC3);
  cv::randu(bgr, 0, 255);
  ros1::Image image = ros1::imageFromMat(bgr, "bgr8", 1700000000.25);
  image.header.frame_id = "cam";
  const std::vector<uint8_t> bytes = ros2::encodeImage(image);
  // encapsulation 4, sec 4, nanosec 4, frame_id 4 + "cam\0", height 4, width 4, encoding 4 + "bgr8\0",
  // is_bigendian 1, 2 bytes of padding, step 4 (aligned), data length 4, data, padding to a multiple of 4
  // counted in the options' last byte (as Cyclone DDS writes it: ros2_wire_check compares the bytes).
  const size_t fields = 4 + 4 + 4 + (4 + 4) + 4 + 4 + (4 + 5) + 1 + 2 /*pad*/ + 4 + 4 + bgr.total() * 3;
  const size_t pad = (4 - (fields - 4) % 4) % 4;
  EXPECT_EQ(bytes.size(), fields + pad);
  EXPECT_EQ(bytes[0], 0x00);
  EXPECT_EQ(bytes[1], 0x01);  // CDR little-endian
  EXPECT_EQ(bytes[3], pad);
  auto back = ros2::decodeImage(bytes.data(), bytes.size());
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back->header.stamp_sec, 1700000000u);
  EXPECT_EQ(back->header.frame_id, "cam");
  EXPECT_EQ(back->encoding, "bgr8");
  EXPECT_EQ(back->step, 12u);
  auto color = ros1::colorFromImage(*back);
  ASSERT_TRUE(color) << color.error();
  EXPECT_EQ(cv::norm(*color, bgr, cv::NORM_INF), 0.0);
  for (size_t n = 0; n < fields; ++n) EXPECT_FALSE(ros2::decodeImage(bytes.data(), n)) << n;
}

TEST(Ros2Messages, BigEndianEncapsulationIsRead) {
  // A 1x1 mono8 image, hand-written big-endian CDR.
  const std::vector<uint8_t> bytes = {0x00, 0x00, 0x00, 0x00,        // CDR_BE
                                      0x00, 0x00, 0x00, 0x07,        // sec 7
                                      0x00, 0x00, 0x00, 0x09,        // nanosec 9
                                      0x00, 0x00, 0x00, 0x01, 0x00,  // frame_id ""
                                      0x00, 0x00, 0x00,              // pad to 4
                                      0x00, 0x00, 0x00, 0x01,        // height 1
                                      0x00, 0x00, 0x00, 0x01,        // width 1
                                      0x00, 0x00, 0x00, 0x06, 'm',  'o', 'n', 'o', '8', 0x00,
                                      0x00,                           // is_bigendian
                                      0x00,                           // pad to 4
                                      0x00, 0x00, 0x00, 0x01,         // step 1
                                      0x00, 0x00, 0x00, 0x01, 0x2A};  // data [42]
  auto m = ros2::decodeImage(bytes.data(), bytes.size());
  ASSERT_TRUE(m) << m.error();
  EXPECT_EQ(m->header.stamp_sec, 7u);
  EXPECT_EQ(m->header.stamp_nsec, 9u);
  EXPECT_EQ(m->encoding, "mono8");
  ASSERT_EQ(m->data.size(), 1u);
  EXPECT_EQ(m->data[0], 42);
}

TEST(Ros2Messages, CameraInfoRoundTripsAndForgedInputIsRefused) {
  ros1::CameraInfo c;
  c.header.stamp_sec = 3;
  c.header.frame_id = "camera_color_optical_frame";
  c.width = 640, c.height = 480;
  c.distortion_model = "plumb_bob";
  c.D = {0.1, -0.2, 0.001, 0.002, 0.3};
  c.K = {517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1};
  const std::vector<uint8_t> bytes = ros2::encodeCameraInfo(c);
  auto back = ros2::decodeCameraInfo(bytes.data(), bytes.size());
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back->D, c.D);
  EXPECT_EQ(back->K, c.K);
  auto camera = ros1::cameraFromInfo(*back);
  ASSERT_TRUE(camera) << camera.error();
  EXPECT_EQ(camera->fx, 517.3);
  for (size_t n = 0; n + 25 + bytes[3] < bytes.size(); ++n)  // binning, roi (25 bytes), padding: not read
    EXPECT_FALSE(ros2::decodeCameraInfo(bytes.data(), n)) << n;
  std::vector<uint8_t> bad = bytes;
  bad[1] = 0x07;  // not plain CDR
  EXPECT_FALSE(ros2::decodeCameraInfo(bad.data(), bad.size()));
  ros1::Image image = ros1::imageFromMat(cv::Mat(2, 2, CV_8UC1, cv::Scalar(1)), "mono8", 1.0);
  std::vector<uint8_t> ib = ros2::encodeImage(image);
  const uint32_t huge = 0xFFFFFFF0u;
  const size_t end = ib.size() - ib[3];            // without the padding
  std::memcpy(ib.data() + end - 4 - 4, &huge, 4);  // the data length
  EXPECT_FALSE(ros2::decodeImage(ib.data(), ib.size()));
  ib = ros2::encodeImage(image);
  std::memcpy(ib.data() + end - 4 - 4 - 4, &huge, 4);  // the step: rows beyond the data
  EXPECT_FALSE(ros2::decodeImage(ib.data(), ib.size()));
}

}  // namespace
}  // namespace rgbdmap
