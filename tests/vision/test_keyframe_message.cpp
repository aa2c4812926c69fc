// Keyframe <-> wire message: what the server reconstructs must equal what the robot's odometry computed.
#include <gtest/gtest.h>

#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

namespace rgbdmap {
namespace {

struct Made {
  std::shared_ptr<const Keyframe> keyframe;
  RgbdFrame frame;
  CameraIntrinsics camera;
};

Made firstKeyframe() {
  SynthConfig cfg;
  cfg.scene = "loop";
  cfg.frames = 3;
  auto scene = SyntheticScene::build(cfg);
  EXPECT_TRUE(scene) << scene.error();
  Made m;
  if (!scene) return m;
  m.camera = cfg.camera;
  m.frame = scene->renderFrame(0);
  VisualOdometry vo(cfg.camera, OdometryConfig{});
  m.keyframe = vo.track(m.frame).new_keyframe;
  return m;
}

TEST(KeyframeMessage, RoundTripThroughTheWireKeepsTheFeatures) {
  const Made m = firstKeyframe();
  ASSERT_TRUE(m.keyframe);
  const FrameFeatures& f = m.keyframe->features;
  ASSERT_GT(f.size(), 100u);
  auto images = encodeImages(m.frame);
  ASSERT_TRUE(images) << images.error();
  auto message = keyframeToMessage(*m.keyframe, "robot7", *images);
  ASSERT_TRUE(message) << message.error();
  EXPECT_EQ(message->robot_id, "robot7");
  EXPECT_EQ(message->keyframe_id, m.keyframe->id);
  EXPECT_EQ(message->previous_keyframe_id, -1);
  message->header.sender = "robot7";  // msg::Signer::seal sets the header in the service
  auto bytes = msg::encodePayload(*message);
  ASSERT_TRUE(bytes) << bytes.error();
  auto decoded = msg::decodePayload<msg::Keyframe>(*bytes);
  ASSERT_TRUE(decoded) << decoded.error();

  const PinholeCamera camera(m.camera);
  auto back = featuresFromMessage(*decoded, camera);
  ASSERT_TRUE(back) << back.error();
  ASSERT_EQ(back->size(), f.size());
  EXPECT_EQ(cv::norm(back->descriptors, f.descriptors, cv::NORM_HAMMING), 0.0);
  for (size_t i = 0; i < f.size(); ++i) {
    EXPECT_EQ(back->keypoints[i].octave, f.keypoints[i].octave);
    EXPECT_NEAR((back->px[i] - f.px[i]).norm(), 0.0, 1e-4);
    EXPECT_NEAR(back->depth_m[i], f.depth_m[i], 1e-6);
    if (f.hasDepth(i)) {
      EXPECT_NEAR((back->p_cam[i] - f.p_cam[i]).norm(), 0.0, 1e-5);
    }
  }
}

TEST(KeyframeMessage, MismatchedDescriptorsAreRefused) {
  const Made m = firstKeyframe();
  ASSERT_TRUE(m.keyframe);
  auto message = keyframeToMessage(*m.keyframe, "robot7", EncodedImages{});
  ASSERT_TRUE(message) << message.error();
  message->descriptors.pop_back();
  EXPECT_FALSE(featuresFromMessage(*message, PinholeCamera(m.camera)));
  Keyframe broken = *m.keyframe;
  broken.features.descriptors = broken.features.descriptors.rowRange(0, 10).clone();
  EXPECT_FALSE(keyframeToMessage(broken, "robot7", EncodedImages{}));
}

TEST(KeyframeMessage, NonFiniteInformationIsSentAsZero) {
  const Made m = firstKeyframe();
  ASSERT_TRUE(m.keyframe);
  Keyframe k = *m.keyframe;
  k.information = Mat6::Identity();
  k.information(2, 2) = std::nan("");
  auto message = keyframeToMessage(k, "r", EncodedImages{});
  ASSERT_TRUE(message) << message.error();
  EXPECT_TRUE(message->information.isZero());
}

// Sent without features, a keyframe carries only its images; the server's extraction from the decoded
// JPEG finds the robot's keypoints again (same extractor configuration): most within a pixel, with depth
// from the lossless depth, and descriptors close in Hamming distance. Stored with putFeatures, the
// extracted features read back exactly.
TEST(KeyframeMessage, WithoutFeaturesTheServerExtractsThemFromTheImages) {
  const Made m = firstKeyframe();
  ASSERT_TRUE(m.keyframe);
  const FrameFeatures& robot = m.keyframe->features;
  auto images = encodeImages(m.frame);
  ASSERT_TRUE(images) << images.error();
  auto message = keyframeToMessage(*m.keyframe, "robot7", *images, false);
  ASSERT_TRUE(message) << message.error();
  EXPECT_TRUE(message->keypoints.empty());
  EXPECT_TRUE(message->descriptors.empty());
  EXPECT_TRUE(needsServerFeatures(*message));

  auto decoded = decodeImages(message->images);
  ASSERT_TRUE(decoded) << decoded.error();
  const OrbExtractor extractor{OrbConfig{}};
  const FrameFeatures server = extractServerFeatures(extractor, *decoded, m.camera);
  ASSERT_GT(server.size(), robot.size() * 8 / 10);
  size_t found = 0, close_descriptor = 0, same_depth = 0;
  for (size_t i = 0; i < robot.size(); ++i) {
    for (size_t j = 0; j < server.size(); ++j) {
      if (server.keypoints[j].octave != robot.keypoints[i].octave ||
          cv::norm(server.keypoints[j].pt - robot.keypoints[i].pt) > 1.0)
        continue;
      ++found;
      same_depth += std::abs(server.depth_m[j] - robot.depth_m[i]) <= 0.05;  // not when moved onto an edge
      close_descriptor += cv::norm(server.descriptors.row(static_cast<int>(j)),
                                   robot.descriptors.row(static_cast<int>(i)), cv::NORM_HAMMING) <= 40;
      break;
    }
  }
  EXPECT_GT(found, robot.size() * 7 / 10);
  EXPECT_GT(close_descriptor, found * 8 / 10);
  EXPECT_GT(same_depth, found * 95 / 100);

  ASSERT_TRUE(putFeatures(server, &*message));
  EXPECT_FALSE(needsServerFeatures(*message));
  auto back = featuresFromMessage(*message, PinholeCamera(m.camera));
  ASSERT_TRUE(back) << back.error();
  ASSERT_EQ(back->size(), server.size());
  EXPECT_EQ(cv::norm(back->descriptors, server.descriptors, cv::NORM_HAMMING), 0.0);

  EncodedImages depth_only = *images;
  depth_only.color_codec = ColorCodec::kNone;
  depth_only.color.clear();
  EXPECT_FALSE(keyframeToMessage(*m.keyframe, "robot7", depth_only, false));
}

}  // namespace
}  // namespace rgbdmap
