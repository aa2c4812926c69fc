// Seeded corruption of ROS 2 CDR messages, as a ROS 2 topic or bag may deliver them from an untrusted peer:
// 100,000 mutants of valid sensor_msgs/msg/Image (every encoding the sources take) and CameraInfo
// encodings - flipped bytes, truncations, forged lengths and sizes at random field positions. Every mutant
// decodes to an error or to a message whose data fits its declared sizes, and the conversions to OpenCV
// either succeed or say why; never a crash (the sanitizer pass of deploy/test.sh runs this too).
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include "rgbdmap/source/ros2_messages.hpp"

namespace rgbdmap {
namespace {

std::vector<std::vector<uint8_t>> validMessages() {
  std::vector<std::vector<uint8_t>> out;
  cv::Mat bgr(6, 8, CV_8UC3), mono(6, 8, CV_8UC1), mm(6, 8, CV_16UC1), metres(6, 8, CV_32FC1);
  cv::randu(bgr, 0, 255);
  cv::randu(mono, 0, 255);
  cv::randu(mm, 0, 5000);
  cv::randu(metres, 0.0f, 5.0f);
  for (const auto& [mat, encoding] :
       {std::pair{bgr, "bgr8"}, std::pair{bgr, "rgb8"}, std::pair{mono, "mono8"}, std::pair{mm, "16UC1"},
        std::pair{metres, "32FC1"}})
    out.push_back(ros2::encodeImage(ros1::imageFromMat(mat, encoding, 1700000000.5)));
  ros1::CameraInfo c;
  c.distortion_model = "plumb_bob";
  c.D = {0.1, -0.2, 0.001, 0.002, 0.3};
  c.K = {517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1};
  c.width = 640, c.height = 480;
  out.push_back(ros2::encodeCameraInfo(c));
  return out;
}

TEST(Ros2Fuzz, HundredThousandMutantsDecodeToAnErrorOrAConsistentMessage) {
  const auto valid = validMessages();
  std::mt19937 rng(2026);
  int decoded = 0, refused = 0;
  for (int i = 0; i < 100000; ++i) {
    const size_t which = rng() % valid.size();
    std::vector<uint8_t> m = valid[which];
    switch (rng() % 4) {
      case 0:  // flipped bytes
        for (int f = 1 + static_cast<int>(rng() % 6); f > 0; --f)
          m[rng() % m.size()] = static_cast<uint8_t>(rng());
        break;
      case 1:  // truncated
        m.resize(rng() % m.size());
        break;
      case 2: {  // a forged 32-bit length or size at a random aligned position
        const uint32_t forged[] = {0xFFFFFFFFu, 0x80000000u, 0x7FFFFFFFu,
                                   0u,          1u,          static_cast<uint32_t>(m.size())};
        const size_t at = 4 + 4 * (rng() % ((m.size() - 4) / 4));
        std::memcpy(m.data() + at, &forged[rng() % 6], 4);
        break;
      }
      default:  // extended with garbage
        for (int k = static_cast<int>(rng() % 64); k > 0; --k) m.push_back(static_cast<uint8_t>(rng()));
    }
    if (which + 1 == valid.size()) {
      auto info = ros2::decodeCameraInfo(m.data(), m.size());
      if (!info) {
        ++refused;
        continue;
      }
      ++decoded;
      EXPECT_LE(info->D.size(), 64u);
      (void)ros1::cameraFromInfo(*info);
      continue;
    }
    auto image = ros2::decodeImage(m.data(), m.size());
    if (!image) {
      ++refused;
      continue;
    }
    ++decoded;
    ASSERT_LE(static_cast<uint64_t>(image->step) * image->height, image->data.size()) << i;
    ASSERT_LE(image->data.size(), m.size()) << i;
    double scale = 0;
    (void)ros1::colorFromImage(*image);
    (void)ros1::depthFromImage(*image, &scale);
  }
  std::printf("[ measured ] 100000 CDR mutants: %d decoded, %d refused with a reason\n", decoded, refused);
  EXPECT_GT(refused, 30000);
  EXPECT_GT(decoded, 10000);  // flipped pixel bytes and trailing garbage still decode
}

}  // namespace
}  // namespace rgbdmap
