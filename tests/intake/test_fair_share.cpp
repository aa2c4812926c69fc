// Fair share, the server's private parts: per-robot queues served round-robin and bounded,
// the per-robot token bucket, and the refusal of images from their headers before decoding.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "rgbdmap/intake/image_admission.hpp"
#include "rgbdmap/intake/keyframe_throttle.hpp"
#include "rgbdmap/intake/robot_queues.hpp"

namespace rgbdmap {
namespace {

msg::Keyframe keyframe(const std::string& robot, int id) {
  msg::Keyframe kf;
  kf.robot_id = robot;
  kf.keyframe_id = id;
  return kf;
}

constexpr RobotQueues::Pushed kQueued = RobotQueues::Pushed::kQueued;
constexpr RobotQueues::Pushed kFull = RobotQueues::Pushed::kFull;
constexpr RobotQueues::Pushed kDuplicate = RobotQueues::Pushed::kDuplicate;

TEST(RobotQueues, ServesRobotsInTurnWhateverTheirQueueLengths) {
  RobotQueues queues({100, 1u << 30, 1000});
  for (int i = 0; i < 50; ++i) ASSERT_EQ(queues.push("flood", keyframe("flood", i), 10), kQueued);
  ASSERT_EQ(queues.push("good", keyframe("good", 0), 10), kQueued);
  ASSERT_EQ(queues.push("good", keyframe("good", 1), 10), kQueued);
  std::vector<std::string> order;
  for (int i = 0; i < 6; ++i) order.push_back(queues.pop()->robot_id);
  // "flood" was first in turn; "good" gets every other keyframe from then on.
  EXPECT_EQ(order, (std::vector<std::string>{"flood", "good", "flood", "good", "flood", "flood"}));
  EXPECT_EQ(queues.size(), 46u);
  EXPECT_EQ(queues.size("good"), 0u);
}

TEST(RobotQueues, ADemotedRobotIsServedOnlyWhenNoOtherRobotWaits) {
  using Clock = RobotQueues::Clock;
  RobotQueues queues({100, 1u << 30, 1000});
  const Clock::time_point t0 = Clock::now();
  for (int i = 0; i < 10; ++i) ASSERT_EQ(queues.push("flood", keyframe("flood", i), 10), kQueued);
  ASSERT_EQ(queues.push("good", keyframe("good", 0), 10), kQueued);
  ASSERT_EQ(queues.push("good", keyframe("good", 1), 10), kQueued);
  queues.demote("flood", t0 + std::chrono::seconds(5));
  std::vector<std::string> order;
  for (int i = 0; i < 4; ++i) order.push_back(queues.pop(t0)->robot_id);
  EXPECT_EQ(order, (std::vector<std::string>{"good", "good", "flood", "flood"}));
  ASSERT_EQ(queues.push("good", keyframe("good", 2), 10), kQueued);
  EXPECT_EQ(queues.pop(t0)->robot_id, "good") << "still demoted";
  ASSERT_EQ(queues.push("good", keyframe("good", 3), 10), kQueued);
  EXPECT_EQ(queues.pop(t0 + std::chrono::seconds(6))->robot_id, "flood") << "its turn again once it expired";
  EXPECT_EQ(queues.pop(t0 + std::chrono::seconds(6))->robot_id, "good");
}

TEST(RobotQueues, KeepsEachRobotsOrder) {
  RobotQueues queues({100, 1u << 30, 1000});
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(queues.push("a", keyframe("a", i), 1), kQueued);
    ASSERT_EQ(queues.push("b", keyframe("b", 10 + i), 1), kQueued);
  }
  std::vector<int> a, b;
  while (auto kf = queues.pop()) (kf->robot_id == "a" ? a : b).push_back(kf->keyframe_id);
  EXPECT_EQ(a, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(b, (std::vector<int>{10, 11, 12, 13, 14}));
  EXPECT_FALSE(queues.pop());
}

TEST(RobotQueues, AFullRobotQueueRefusesOnlyThatRobot) {
  RobotQueues queues({3, 1u << 30, 1000});
  for (int i = 0; i < 3; ++i) ASSERT_EQ(queues.push("flood", keyframe("flood", i), 10), kQueued);
  EXPECT_FALSE(queues.hasRoom("flood", 10));
  EXPECT_EQ(queues.push("flood", keyframe("flood", 3), 10), kFull);
  EXPECT_EQ(queues.push("good", keyframe("good", 0), 10), kQueued);
  EXPECT_EQ(queues.size("flood"), 3u);
  EXPECT_EQ(queues.highWater("flood"), 3u);
  (void)queues.pop();
  EXPECT_EQ(queues.push("flood", keyframe("flood", 3), 10), kQueued) << "room again after a pop";
}

// A robot whose acknowledgements are late resends what is still queued: the copies take no slot, so its
// queue is not "full" of a few keyframes and it is not demoted for the server's own delay.
TEST(RobotQueues, AResentKeyframeStillQueuedTakesNoSecondSlot) {
  RobotQueues queues({3, 1u << 30, 1000});
  ASSERT_EQ(queues.push("r", keyframe("r", 0), 10), kQueued);
  ASSERT_EQ(queues.push("r", keyframe("r", 1), 10), kQueued);
  for (int round = 0; round < 5; ++round) {
    EXPECT_EQ(queues.push("r", keyframe("r", 0), 10), kDuplicate);
    EXPECT_EQ(queues.push("r", keyframe("r", 1), 10), kDuplicate);
  }
  EXPECT_EQ(queues.size("r"), 2u);
  EXPECT_EQ(queues.push("r", keyframe("r", 2), 10), kQueued) << "the third slot is still free";
  EXPECT_EQ(queues.push("r", keyframe("r", 1), 10), kDuplicate) << "a copy is told apart even when full";
  EXPECT_EQ(queues.push("r", keyframe("r", 3), 10), kFull);
  // Another session or segment, or another robot, is another keyframe.
  msg::Keyframe other_session = keyframe("r", 0);
  other_session.header.session = 7;
  EXPECT_EQ(queues.push("r", other_session, 10), kFull);
  msg::Keyframe other_segment = keyframe("r", 0);
  other_segment.segment_id = 1;
  EXPECT_FALSE(queues.contains("r", other_segment));
  EXPECT_TRUE(queues.contains("r", keyframe("r", 2)));
  EXPECT_EQ(queues.push("s", keyframe("s", 0), 10), kQueued);
  // Once served, a copy is queued again (the ingest answers it as a duplicate of the stored one).
  EXPECT_EQ(queues.pop()->keyframe_id, 0);
  EXPECT_FALSE(queues.contains("r", keyframe("r", 0)));
  EXPECT_EQ(queues.push("r", keyframe("r", 0), 10), kQueued);
}

TEST(RobotQueues, BytesAndTheTotalAreBounded) {
  RobotQueues queues({100, 1000, 4});
  ASSERT_EQ(queues.push("a", keyframe("a", 0), 5000), kQueued) << "one keyframe always fits an empty queue";
  EXPECT_EQ(queues.push("a", keyframe("a", 1), 1), kFull) << "over the byte bound";
  ASSERT_EQ(queues.push("b", keyframe("b", 0), 600), kQueued);
  EXPECT_EQ(queues.push("b", keyframe("b", 1), 600), kFull);
  ASSERT_EQ(queues.push("b", keyframe("b", 1), 400), kQueued);
  EXPECT_EQ(queues.bytes("b"), 1000u);
  ASSERT_EQ(queues.push("c", keyframe("c", 0), 1), kQueued);
  EXPECT_EQ(queues.push("d", keyframe("d", 0), 1), kFull) << "the total of all robots";
  queues.clear();
  EXPECT_EQ(queues.size(), 0u);
  EXPECT_FALSE(queues.pop());
}

TEST(KeyframeThrottle, ABurstThenTheRateAndRobotsAreIndependent) {
  using Clock = KeyframeThrottle::Clock;
  KeyframeThrottle throttle(10.0, 5.0);
  const Clock::time_point t0 = Clock::now();
  int allowed = 0;
  for (int i = 0; i < 100; ++i) allowed += throttle.allow("flood", t0);
  EXPECT_EQ(allowed, 5) << "the burst";
  EXPECT_TRUE(throttle.allow("good", t0)) << "another robot has its own bucket";
  // One second later: 10 more tokens (not more than the burst of 5).
  allowed = 0;
  for (int i = 0; i < 100; ++i) allowed += throttle.allow("flood", t0 + std::chrono::seconds(1));
  EXPECT_EQ(allowed, 5);
  // Over 10 s at 100 per second: about the rate.
  allowed = 0;
  for (int ms = 10; ms <= 10000; ms += 10)
    allowed += throttle.allow("flood", t0 + std::chrono::seconds(1) + std::chrono::milliseconds(ms));
  EXPECT_NEAR(allowed, 100, 1);
  // A clock that goes backwards adds nothing.
  EXPECT_FALSE(throttle.allow("flood", t0));
  KeyframeThrottle off(0.0, 1.0);
  for (int i = 0; i < 1000; ++i) ASSERT_TRUE(off.allow("any", t0));
}

/// Encoded images of a constant w x h frame (the codec's own header).
EncodedImages constantImages(int w, int h, ColorCodec codec = ColorCodec::kJpeg) {
  RgbdFrame frame;
  frame.depth = cv::Mat(h, w, CV_16UC1, cv::Scalar(5000));
  frame.color = cv::Mat(h, w, CV_8UC3, cv::Scalar(100, 120, 140));
  ImageCodecOptions options;
  options.color = codec;
  auto encoded = encodeImages(frame, options);
  EXPECT_TRUE(encoded) << encoded.error();
  return encoded ? *encoded : EncodedImages{};
}

CameraIntrinsics camera(int w, int h) {
  CameraIntrinsics c;
  c.width = w;
  c.height = h;
  return c;
}

TEST(ImageAdmission, ImagesOfTheAnnouncedCameraPass) {
  const ImageLimits limits;
  EXPECT_EQ(imagesRefusedBeforeDecode(constantImages(640, 480), camera(640, 480), limits), "");
  EXPECT_EQ(imagesRefusedBeforeDecode(constantImages(64, 48, ColorCodec::kNone), camera(64, 48), limits), "");
}

TEST(ImageAdmission, ASizeOtherThanTheCamerasIsRefusedFromTheHeader) {
  const ImageLimits limits;
  const EncodedImages big = constantImages(4096, 4096);
  const std::string why = imagesRefusedBeforeDecode(big, camera(640, 480), limits);
  EXPECT_NE(why.find("differs from the camera"), std::string::npos) << why;
  // The message's own width and height right, the blob's header not: the header decides.
  EncodedImages forged = constantImages(640, 480);
  forged.depth[6] = 0x00;
  forged.depth[7] = 0x10;  // 4096 wide
  const std::string forged_why = imagesRefusedBeforeDecode(forged, camera(640, 480), limits);
  EXPECT_NE(forged_why.find("depth image declares 4096x480"), std::string::npos) << forged_why;
  EncodedImages color = constantImages(640, 480);
  color.color[8] = 0xFF;
  EXPECT_NE(imagesRefusedBeforeDecode(color, camera(640, 480), limits).find("colour image declares"),
            std::string::npos);
}

TEST(ImageAdmission, ACameraOverThePixelBoundAndBlobsOverTheByteBoundAreRefused) {
  ImageLimits limits;
  const EncodedImages big = constantImages(4096, 4096);
  const std::string why = imagesRefusedBeforeDecode(big, camera(4096, 4096), limits);
  EXPECT_NE(why.find("above server.max_image_pixels"), std::string::npos) << why;
  EncodedImages small = constantImages(640, 480);
  limits.max_image_bytes = small.depth.size() - 1;
  EXPECT_NE(imagesRefusedBeforeDecode(small, camera(640, 480), limits).find("above server.max_image_bytes"),
            std::string::npos);
}

TEST(ImageAdmission, InconsistentBlobsAreRefused) {
  const ImageLimits limits;
  EncodedImages images = constantImages(640, 480);
  images.depth.push_back(0);  // payload length no longer the header's
  EXPECT_NE(imagesRefusedBeforeDecode(images, camera(640, 480), limits).find("payload length"),
            std::string::npos);
  images = constantImages(640, 480);
  images.depth.resize(10);
  EXPECT_NE(imagesRefusedBeforeDecode(images, camera(640, 480), limits).find("without a valid header"),
            std::string::npos);
  images = constantImages(640, 480);
  images.color_codec = ColorCodec::kNone;
  EXPECT_NE(imagesRefusedBeforeDecode(images, camera(640, 480), limits).find("codec none"),
            std::string::npos);
}

}  // namespace
}  // namespace rgbdmap
