#pragma once
// Realistic stored keyframes and loops for the map store tests: 300 keypoints with descriptors and images
// encoded with encodeImages from rendered synthetic frames (640x480, ~100 KB) or small random ones.
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap::testing {

/// Silences the logger for a scope (recovery sweeps reopen thousands of damaged stores).
class QuietLog {
 public:
  QuietLog() : previous_(log::level()) { log::setLevel(log::Level::kOff); }
  ~QuietLog() { log::setLevel(previous_); }
  QuietLog(const QuietLog&) = delete;
  QuietLog& operator=(const QuietLog&) = delete;

 private:
  log::Level previous_;
};

/// Encoded images of two rendered frames of the synthetic loop (rendered once per process).
inline const std::vector<EncodedImages>& renderedImages() {
  static const std::vector<EncodedImages> images = [] {
    SynthConfig config;
    config.frames = 40;
    const SyntheticScene scene = SyntheticScene::build(config).value();
    std::vector<EncodedImages> out;
    for (int i : {0, 20}) out.push_back(encodeImages(scene.renderFrame(i)).value());
    return out;
  }();
  return images;
}

/// Random-content images of width x height (JPEG colour), seeded.
inline EncodedImages randomImages(int width, int height, uint32_t seed) {
  std::mt19937 rng(seed);
  RgbdFrame frame;
  frame.color.create(height, width, CV_8UC3);
  frame.depth.create(height, width, CV_16UC1);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      frame.color.at<cv::Vec3b>(y, x) = cv::Vec3b(rng() & 255, rng() & 255, rng() & 255);
      frame.depth.at<uint16_t>(y, x) = static_cast<uint16_t>(rng() % 20000);
    }
  return encodeImages(frame).value();
}

/// A valid keyframe of robot `robot` with `keypoints` features and the given images.
inline StoredKeyframe makeKeyframe(int64_t node_id, int robot, const EncodedImages& images,
                                   int keypoints = 300) {
  std::mt19937 rng(static_cast<uint32_t>(node_id * 7919 + 13));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  StoredKeyframe s;
  s.node_id = node_id;
  s.session = 1000 + robot;
  msg::Keyframe& k = s.keyframe;
  k.robot_id = "robot_" + std::to_string(robot);
  k.header.sender = k.robot_id;
  k.header.session = s.session;
  k.header.seq = node_id;
  k.header.utime = 1700000000000000 + node_id;
  k.segment_id = 0;
  k.keyframe_id = static_cast<int>(node_id);
  k.previous_keyframe_id = static_cast<int>(node_id) - 1;
  k.timestamp = 1000.0 + 0.5 * static_cast<double>(node_id);
  k.T_odom_cam = se3::exp((Vec6() << u(rng), u(rng), u(rng), 0.3 * u(rng), 0.3 * u(rng), u(rng)).finished());
  k.T_prev_cur = se3::exp((Vec6() << 0.1 * u(rng), 0.0, 0.05, 0.01, 0.02 * u(rng), 0.0).finished());
  k.information = Mat6::Identity() * (100.0 + node_id);
  k.information(0, 3) = k.information(3, 0) = 1.5;
  k.images = images;
  for (int i = 0; i < keypoints; ++i) {
    k.keypoints.push_back({static_cast<float>(u(rng) * (images.width - 1)),
                           static_cast<float>(u(rng) * (images.height - 1)), i % 8,
                           static_cast<float>(u(rng) * 360.0), static_cast<float>(u(rng) * 50.0),
                           i % 4 ? static_cast<float>(0.5 + 3.0 * u(rng)) : 0.0f});
  }
  k.descriptors.resize(static_cast<size_t>(keypoints) * msg::kDescriptorBytes);
  for (uint8_t& b : k.descriptors) b = static_cast<uint8_t>(rng());
  return s;
}

inline StoredLoop makeLoop(int64_t from, int64_t to) {
  StoredLoop loop;
  loop.from_node = from;
  loop.to_node = to;
  loop.T_from_to = se3::exp((Vec6() << 0.3, -0.1, 0.02 * from, 0.1, 0.2, -0.05 * to).finished());
  loop.information = Mat6::Identity() * 250.0;
  loop.information(1, 4) = loop.information(4, 1) = -3.25;
  loop.inliers = static_cast<int>(40 + from);
  loop.motion_measure = 0.125 * static_cast<double>(to);
  // Odd sources carry their verified feature matches; even ones are the original record without them.
  if (from % 2 == 1)
    for (int i = 0; i < 50; ++i) loop.inlier_pairs.emplace_back(3 * i + static_cast<int>(from), 499 - i);
  return loop;
}

/// Every field; with_images: the images and features too (byte-identical blobs), else `a` must have
/// neither (MapStore::keyframes()).
inline void expectSameKeyframe(const StoredKeyframe& a, const StoredKeyframe& b, bool with_images) {
  EXPECT_EQ(a.node_id, b.node_id);
  EXPECT_EQ(a.session, b.session);
  const msg::Keyframe &p = a.keyframe, &q = b.keyframe;
  EXPECT_EQ(p.header, q.header);
  EXPECT_EQ(p.robot_id, q.robot_id);
  EXPECT_EQ(p.segment_id, q.segment_id);
  EXPECT_EQ(p.keyframe_id, q.keyframe_id);
  EXPECT_EQ(p.previous_keyframe_id, q.previous_keyframe_id);
  EXPECT_EQ(p.timestamp, q.timestamp);
  EXPECT_TRUE(p.T_odom_cam.isApprox(q.T_odom_cam, 1e-12));
  EXPECT_TRUE(p.T_prev_cur.isApprox(q.T_prev_cur, 1e-12));
  EXPECT_EQ(p.information, q.information);
  if (!with_images) {  // what the store keeps in memory
    EXPECT_TRUE(p.keypoints.empty() && p.descriptors.empty()) << "features kept in memory";
    EXPECT_TRUE(p.images.depth.empty() && p.images.color.empty()) << "images kept in memory";
  } else {
    ASSERT_EQ(p.keypoints.size(), q.keypoints.size());
    for (size_t i = 0; i < p.keypoints.size(); ++i) {
      const msg::KeyPoint &x = p.keypoints[i], &y = q.keypoints[i];
      EXPECT_TRUE(x.u == y.u && x.v == y.v && x.octave == y.octave && x.angle_deg == y.angle_deg &&
                  x.response == y.response && x.depth_m == y.depth_m)
          << "keypoint " << i;
    }
    EXPECT_EQ(p.descriptors, q.descriptors);
  }
  EXPECT_EQ(p.images.width, q.images.width);
  EXPECT_EQ(p.images.height, q.images.height);
  EXPECT_EQ(p.images.color_codec, q.images.color_codec);
  if (with_images) {
    EXPECT_TRUE(p.images.depth == q.images.depth) << "depth blob differs";
    EXPECT_TRUE(p.images.color == q.images.color) << "colour blob differs";
  }
}

inline void expectSameLoop(const StoredLoop& a, const StoredLoop& b) {
  EXPECT_EQ(a.from_node, b.from_node);
  EXPECT_EQ(a.to_node, b.to_node);
  EXPECT_EQ(a.T_from_to.matrix(), b.T_from_to.matrix());  // stored as 12 doubles: bit-exact
  EXPECT_EQ(a.information, b.information);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.motion_measure, b.motion_measure);
  EXPECT_EQ(a.inlier_pairs, b.inlier_pairs);
}

inline std::unique_ptr<MapStore> openStore(const std::string& dir, bool sync = false) {
  Result<std::unique_ptr<MapStore>> store = MapStore::open(dir, MapStoreOptions{sync});
  EXPECT_TRUE(store) << store.error();
  return store ? std::move(store).value() : nullptr;
}

}  // namespace rgbdmap::testing
