#pragma once
// Valid sample messages of every type, for the proto tests and fuzzing.
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/map_payload.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::testing {

using msg::Bytes;

inline Bytes testKey(uint8_t seed) {
  Bytes key(32);
  for (size_t i = 0; i < key.size(); ++i) key[i] = static_cast<uint8_t>(seed * 31 + i * 7);
  return key;
}

inline SE3 samplePose(double a) {
  return se3::exp((Vec6() << 0.1 + a, -0.2, 0.3 * a, 0.05, -0.1 * a, 0.2).finished());
}

/// Images of the given size; `noise` (0..255) makes the JPEG larger.
inline EncodedImages sampleImages(int width, int height, int noise, ColorCodec codec = ColorCodec::kJpeg) {
  RgbdFrame frame;
  frame.color.create(height, width, CV_8UC3);
  frame.depth.create(height, width, CV_16UC1);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> n(0, std::max(noise, 0));
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      frame.color.at<cv::Vec3b>(y, x) =
          cv::Vec3b((x + n(rng)) & 255, (y + n(rng)) & 255, ((x ^ y) + n(rng)) & 255);
      frame.depth.at<uint16_t>(y, x) = static_cast<uint16_t>((x * 3 + y * 5) % 20000 + (noise ? n(rng) : 0));
    }
  }
  ImageCodecOptions options;
  options.color = codec;
  options.max_keyframe_bytes = 0;
  return encodeImages(frame, options).value();
}

inline msg::Keyframe sampleKeyframe(int num_keypoints = 50, int width = 64, int height = 48, int noise = 0) {
  msg::Keyframe k;
  k.robot_id = "robot_1";
  k.segment_id = 2;
  k.keyframe_id = 17;
  k.timestamp = 1305031102.175304;
  k.T_odom_cam = samplePose(0.3);
  k.previous_keyframe_id = 16;
  k.T_prev_cur = samplePose(-0.1);
  Mat6 A = Mat6::Identity() * 4.0;
  A(0, 1) = A(1, 0) = 0.5;
  k.information = A * A.transpose();
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < num_keypoints; ++i) {
    k.keypoints.push_back({u(rng) * (width - 1), u(rng) * (height - 1), i % 8, u(rng) * 360.0f,
                           u(rng) * 100.0f, i % 3 ? u(rng) * 5.0f : 0.0f});
  }
  k.descriptors.resize(num_keypoints * msg::kDescriptorBytes);
  for (auto& b : k.descriptors) b = static_cast<uint8_t>(rng());
  k.images = sampleImages(width, height, noise);
  return k;
}

inline msg::Hello sampleHello() {
  msg::Hello m;
  m.robot_id = "robot_1";
  m.software_version = "rgbdmap 0.1.0 (test)";
  m.capabilities = {"keyframes", "cmd_vel"};
  m.T_base_camera = CameraMount{{0.1, -0.05, 0.45}, {0.0, 12.0, -3.0}}.T_base_camera();
  m.camera.readout_s = 0.0275;
  return m;
}

inline msg::RobotPose sampleRobotPose() {
  msg::RobotPose m;
  m.robot_id = "robot_1";
  m.timestamp = 1305031102.211;
  m.segment_id = 1;
  m.reference_keyframe_id = 16;
  m.tracking_state = 1;
  m.graph_revision = 7;
  m.T_map_cam = samplePose(0.7);
  return m;
}

inline msg::LinkStatus sampleLinkStatus() {
  msg::LinkStatus m;
  m.robot_id = "robot_1";
  m.keyframes_made = 40;
  m.keyframes_acked = 31;
  m.in_flight = 4;
  m.queued = 5;
  m.spool_depth = 9;
  m.spool_bytes = 540000;
  m.oldest_unanswered_s = 12.5;
  m.live_only = true;
  m.diagnosis = "no server heard";
  return m;
}

inline msg::Heartbeat sampleHeartbeat() { return {{}, "robot_1", 16, 2, 1, 123.5}; }
inline msg::KeyframeAck sampleAck() { return {{}, "robot_1", 17, false, "duplicate keyframe"}; }

/// Chunk 2 (the last) of a 2,600-byte transfer in chunks of 1,200 bytes.
inline msg::KeyframeChunk sampleChunk() {
  msg::KeyframeChunk m;
  m.robot_id = "robot_1";
  m.transfer_id = 77;
  m.keyframe_id = 17;
  m.chunk_index = 2;
  m.chunk_count = 3;
  m.chunk_bytes = 1200;
  m.total_bytes = 2600;
  m.last_of_burst = true;
  m.data.assign(200, 0x5a);
  return m;
}

inline msg::ChunkAck sampleChunkAck() {
  msg::ChunkAck m;
  m.robot_id = "robot_1";
  m.transfer_id = 77;
  m.keyframe_id = 17;
  m.chunk_count = 11;
  m.received = {0xfb, 0x03};
  return m;
}

inline msg::PoseCorrections sampleCorrections() {
  msg::PoseCorrections m;
  m.robot_id = "robot_1";
  m.graph_revision = 42;
  m.T_map_odom = samplePose(0.7);
  for (int i = 0; i < 20; ++i) m.keyframes.push_back({i, samplePose(0.01 * i)});
  return m;
}

inline msg::LoopEdges sampleLoops() {
  msg::LoopEdges m;
  m.robot_id = "robot_1";
  m.graph_revision = 42;
  m.edges.push_back({"robot_1", 3, "robot_1", 17, false, Vec3(0.1, -0.2, 1.5), Vec3(0.3, -0.1, 2.5)});
  m.edges.push_back({"robot_1", 9, "robot_2", 4, true, Vec3(-1.0, 0.0, 0.5), Vec3(-1.2, 0.1, 0.4)});
  return m;
}

inline msg::OccupancySlice sampleSlice() {
  msg::OccupancySlice m;
  m.robot_id = "robot_1";
  m.T_map_grid = samplePose(0.2);
  m.width = 40;
  m.height = 30;
  for (int i = 0; i < m.width * m.height; ++i)
    m.cells.push_back(static_cast<int8_t>(i % 3 == 0 ? -1 : i % 101));
  return m;
}

inline msg::MapUpdate sampleMap() {
  msg::MapUpdate m;
  m.map_revision = 5;
  m.full = false;
  m.robot_keyframe_id = 23;
  Bytes octree(5000);
  for (size_t i = 0; i < octree.size(); ++i) octree[i] = static_cast<uint8_t>(i / 10);
  msg::setMapBytes(octree, msg::MapCompression::kZstd, &m);
  return m;
}

inline msg::VelocityCommand sampleVelocity() {
  return {{}, "robot_1", Vec3(0.3, 0, 0), Vec3(0, 0, 0.2), 0.5};
}

inline msg::ServerStatus sampleStatus() {
  msg::ServerStatus m;
  m.uptime_s = 12.5;
  m.graph_revision = 42;
  m.map_revision = 5;
  m.robots = {{"robot_1", 17, 2, 3, 1700000000000000, false, true},
              {"robot_2", 5, 0, 0, 1700000000000001, true, false}};
  return m;
}

/// One valid signed envelope of every message type (robot messages from robot_1, the rest from the server).
inline std::vector<Bytes> sampleEnvelopes(msg::Signer* robot, msg::Signer* server) {
  const int64_t t = 1700000000000000;
  return {robot->seal(sampleHello(), t).value(),        robot->seal(sampleHeartbeat(), t).value(),
          robot->seal(sampleKeyframe(), t).value(),     server->seal(sampleAck(), t).value(),
          server->seal(sampleCorrections(), t).value(), server->seal(sampleSlice(), t).value(),
          server->seal(sampleMap(), t).value(),         server->seal(sampleVelocity(), t).value(),
          server->seal(sampleStatus(), t).value(),      robot->seal(sampleChunk(), t).value(),
          server->seal(sampleChunkAck(), t).value(),    server->seal(sampleLoops(), t).value(),
          robot->seal(sampleRobotPose(), t).value(),    robot->seal(sampleLinkStatus(), t).value()};
}

}  // namespace rgbdmap::testing
