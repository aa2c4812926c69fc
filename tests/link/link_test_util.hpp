#pragma once
// Keyframes, frames, keys and link options for the RobotLink tests.
#include <chrono>
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::testing {

inline msg::Bytes linkKey(uint8_t seed) {
  msg::Bytes key(32);
  for (size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(seed * 31 + i * 7);
  return key;
}

inline std::unique_ptr<transport::Transport> makeMemq() {
  auto t = transport::makeTransport("memq://");
  EXPECT_TRUE(t.ok()) << t.error();
  return std::move(t).value();
}

/// A small 64x48 frame with textured colour and depth 1.5 m.
inline RgbdFrame smallFrame(int seed) {
  RgbdFrame f;
  f.timestamp = 100.0 + seed;
  f.color.create(48, 64, CV_8UC3);
  cv::randu(f.color, cv::Scalar::all(0), cv::Scalar::all(255));
  f.depth = cv::Mat(48, 64, CV_16UC1, cv::Scalar(7500));
  return f;
}

/// A keyframe with 20 keypoints inside the 64x48 image.
inline Keyframe smallKeyframe(int id, int segment, const SE3& T_odom_cam, int previous_id = -1) {
  Keyframe kf;
  kf.id = id;
  kf.segment = segment;
  kf.frame_index = id;
  kf.timestamp = 100.0 + id;
  kf.T_odom_cam = T_odom_cam;
  kf.previous_id = previous_id;
  std::mt19937 rng(static_cast<unsigned>(id));
  std::uniform_real_distribution<float> u(1.0f, 47.0f);
  const int n = 20;
  kf.features.descriptors.create(n, 32, CV_8U);
  cv::randu(kf.features.descriptors, cv::Scalar::all(0), cv::Scalar::all(255));
  for (int i = 0; i < n; ++i) {
    kf.features.keypoints.emplace_back(u(rng), u(rng), 31.0f, 10.0f * i, 1.0f, i % 4);
    kf.features.px.emplace_back(kf.features.keypoints.back().pt.x, kf.features.keypoints.back().pt.y);
    kf.features.depth_m.push_back(1.5);
    kf.features.p_cam.push_back(Vec3(0, 0, 1.5));
  }
  return kf;
}

/// x-translation and a z-rotation: a distinct pose per a.
inline SE3 testPose(double a) {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(0.3 * a, Vec3::UnitZ()).toRotationMatrix() *
               Eigen::AngleAxisd(0.1 * a, Vec3::UnitX()).toRotationMatrix();
  T.translation() = Vec3(0.5 * a, -0.2 * a, 0.1 + 0.05 * a);
  return T;
}

/// Fast timers for tests: 20 ms first retransmission, 50 ms heartbeats.
inline RobotLinkOptions linkOptions(const std::string& robot_id, const msg::Bytes& key) {
  RobotLinkOptions o;
  o.robot_id = robot_id;
  o.key = key;
  o.camera = CameraIntrinsics{525.0, 525.0, 31.5, 23.5, 64, 48, {0, 0, 0, 0, 0}, 5000.0, 0.0};
  o.reliable.initial_backoff = std::chrono::milliseconds(20);
  o.reliable.max_backoff = std::chrono::milliseconds(100);
  o.heartbeat_period_s = 0.05;
  o.hello_period_s = 0.05;
  o.send_timeout_s = 5.0;
  return o;
}

inline msg::KeyframeAck makeAck(const std::string& robot_id, int keyframe_id, bool accepted = true,
                                const std::string& reason = "") {
  msg::KeyframeAck ack;
  ack.robot_id = robot_id;
  ack.keyframe_id = keyframe_id;
  ack.accepted = accepted;
  ack.reason = reason;
  return ack;
}

inline double maxPoseDifference(const SE3& a, const SE3& b) {
  return std::max((a.translation() - b.translation()).cwiseAbs().maxCoeff(),
                  (a.linear() - b.linear()).cwiseAbs().maxCoeff());
}

}  // namespace rgbdmap::testing
