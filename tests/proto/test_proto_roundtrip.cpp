// Round trip of every message: internal -> payload -> internal, and through a signed envelope.
#include <gtest/gtest.h>

#include <cmath>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/validate.hpp"
#include "rgbdmap_lcm/keyframe_t.hpp"

namespace rgbdmap::msg {
namespace {

using testing::testKey;

/// Signs as the right sender, opens with a fresh guard, decodes; fails the test on any error.
template <typename T>
T throughEnvelope(const T& message) {
  const bool from_robot = directionOf(T::kType) == Direction::kRobotToServer;
  Signer signer(from_robot ? "robot_1" : kServerId, testKey(1), 99);
  KeyStore keys;
  EXPECT_TRUE(keys.add(signer.sender(), testKey(1)));
  ReplayGuard guard;
  Result<Bytes> bytes = signer.seal(message, 1700000000000000);
  EXPECT_TRUE(bytes) << bytes.error();
  Result<OpenedEnvelope> opened = openEnvelope(*bytes, keys, &guard);
  EXPECT_TRUE(opened) << opened.error();
  EXPECT_TRUE(opened->authenticated);
  EXPECT_EQ(opened->header.seq, 0);
  EXPECT_EQ(opened->header.session, 99);
  Result<T> decoded = decodeMessage<T>(*opened);
  EXPECT_TRUE(decoded) << decoded.error();
  EXPECT_EQ(decoded->header, opened->header);
  return decoded.value();
}

void expectPose(const SE3& a, const SE3& b) {
  EXPECT_TRUE(a.isApprox(b, 1e-12)) << a.matrix() << "\n" << b.matrix();
}

void expectKeyframe(const Keyframe& a, const Keyframe& b) {
  EXPECT_EQ(a.robot_id, b.robot_id);
  EXPECT_EQ(a.segment_id, b.segment_id);
  EXPECT_EQ(a.keyframe_id, b.keyframe_id);
  EXPECT_EQ(a.timestamp, b.timestamp);
  expectPose(a.T_odom_cam, b.T_odom_cam);
  EXPECT_EQ(a.previous_keyframe_id, b.previous_keyframe_id);
  expectPose(a.T_prev_cur, b.T_prev_cur);
  EXPECT_EQ(a.information, b.information);
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    const KeyPoint &p = a.keypoints[i], &q = b.keypoints[i];
    EXPECT_TRUE(p.u == q.u && p.v == q.v && p.octave == q.octave && p.angle_deg == q.angle_deg &&
                p.response == q.response && p.depth_m == q.depth_m);
  }
  EXPECT_EQ(a.descriptors, b.descriptors);
  EXPECT_EQ(a.images.width, b.images.width);
  EXPECT_EQ(a.images.height, b.images.height);
  EXPECT_EQ(a.images.color_codec, b.images.color_codec);
  EXPECT_EQ(a.images.depth, b.images.depth);
  EXPECT_EQ(a.images.color, b.images.color);
}

TEST(ProtoRoundTrip, Keyframe) {
  const Keyframe k = testing::sampleKeyframe();
  const Keyframe out = throughEnvelope(k);
  expectKeyframe(k, out);
  Result<DecodedImages> images = decodeKeyframeImages(out);
  ASSERT_TRUE(images) << images.error();
  EXPECT_EQ(images->depth.cols, 64);
  EXPECT_EQ(images->color.rows, 48);
}

TEST(ProtoRoundTrip, Keyframe300KB) {
  const Keyframe k = testing::sampleKeyframe(1000, 640, 480, 96);
  Signer signer("robot_1", testKey(1));
  Result<Bytes> bytes = signer.seal(k, 1);
  ASSERT_TRUE(bytes) << bytes.error();
  EXPECT_GE(bytes->size(), 300000u);
  expectKeyframe(k, throughEnvelope(k));
}

TEST(ProtoRoundTrip, HelloHeartbeatAck) {
  const Hello h = testing::sampleHello(), h2 = throughEnvelope(h);
  EXPECT_EQ(h2.robot_id, h.robot_id);
  EXPECT_EQ(h2.software_version, h.software_version);
  EXPECT_EQ(h2.capabilities, h.capabilities);
  EXPECT_EQ(h2.camera.fx, h.camera.fx);
  EXPECT_EQ(h2.camera.distortion, h.camera.distortion);
  EXPECT_EQ(h2.camera.width, h.camera.width);
  EXPECT_EQ(h2.camera.depth_scale, h.camera.depth_scale);
  EXPECT_EQ(h2.camera.readout_s, 0.0275);
  expectPose(h2.T_base_camera, h.T_base_camera);
  const Heartbeat b = testing::sampleHeartbeat(), b2 = throughEnvelope(b);
  EXPECT_EQ(b2.last_keyframe_id, b.last_keyframe_id);
  EXPECT_EQ(b2.segment_id, b.segment_id);
  EXPECT_EQ(b2.tracking_state, b.tracking_state);
  EXPECT_EQ(b2.uptime_s, b.uptime_s);
  const KeyframeAck a = testing::sampleAck(), a2 = throughEnvelope(a);
  EXPECT_EQ(a2.robot_id, a.robot_id);
  EXPECT_EQ(a2.keyframe_id, a.keyframe_id);
  EXPECT_EQ(a2.accepted, a.accepted);
  EXPECT_EQ(a2.reason, a.reason);
}

TEST(ProtoRoundTrip, PoseCorrectionsAndVelocity) {
  const PoseCorrections c = testing::sampleCorrections(), c2 = throughEnvelope(c);
  EXPECT_EQ(c2.graph_revision, c.graph_revision);
  expectPose(c2.T_map_odom, c.T_map_odom);
  ASSERT_EQ(c2.keyframes.size(), c.keyframes.size());
  for (size_t i = 0; i < c.keyframes.size(); ++i) {
    EXPECT_EQ(c2.keyframes[i].keyframe_id, c.keyframes[i].keyframe_id);
    expectPose(c2.keyframes[i].T_map_cam, c.keyframes[i].T_map_cam);
  }
  const VelocityCommand v = testing::sampleVelocity(), v2 = throughEnvelope(v);
  EXPECT_EQ(v2.linear_mps, v.linear_mps);
  EXPECT_EQ(v2.angular_radps, v.angular_radps);
  EXPECT_EQ(v2.duration_s, v.duration_s);
}

TEST(ProtoRoundTrip, OccupancyMapStatus) {
  const OccupancySlice s = testing::sampleSlice(), s2 = throughEnvelope(s);
  expectPose(s2.T_map_grid, s.T_map_grid);
  EXPECT_EQ(s2.resolution_m, s.resolution_m);
  EXPECT_EQ(s2.width, s.width);
  EXPECT_EQ(s2.height, s.height);
  EXPECT_EQ(s2.z_min_m, s.z_min_m);
  EXPECT_EQ(s2.z_max_m, s.z_max_m);
  EXPECT_EQ(s2.cells, s.cells);
  const MapUpdate m = testing::sampleMap(), m2 = throughEnvelope(m);
  EXPECT_EQ(m2.map_revision, m.map_revision);
  EXPECT_EQ(m2.full, m.full);
  EXPECT_EQ(m2.compression, m.compression);
  EXPECT_EQ(m2.data, m.data);
  EXPECT_EQ(m2.robot_keyframe_id, 23);
  MapUpdate bad_map = m;
  bad_map.robot_keyframe_id = -2;
  EXPECT_FALSE(validate(bad_map));
  Result<Bytes> octree = mapBytes(m2);
  ASSERT_TRUE(octree) << octree.error();
  EXPECT_EQ(octree->size(), 5000u);
  EXPECT_EQ((*octree)[4999], 499 & 255);
  const ServerStatus st = testing::sampleStatus(), st2 = throughEnvelope(st);
  EXPECT_EQ(st2.state, st.state);
  EXPECT_EQ(st2.uptime_s, st.uptime_s);
  ASSERT_EQ(st2.robots.size(), 2u);
  EXPECT_EQ(st2.robots[1].robot_id, "robot_2");
  EXPECT_EQ(st2.robots[0].rejected_messages, 3);
  EXPECT_EQ(st2.robots[1].last_utime, 1700000000000001);
  EXPECT_FALSE(st2.robots[0].localize);
  EXPECT_TRUE(st2.robots[0].placed);
  EXPECT_TRUE(st2.robots[1].localize);
  EXPECT_FALSE(st2.robots[1].placed) << "a localising robot not placed yet";
}

TEST(ProtoRoundTrip, ServerStatusRejectCounts) {
  ServerStatus st = testing::sampleStatus();
  st.rejects = {{"robot_1", "bad_signature", 12}, {"robot_2", "replayed_seq", 1}, {"", "unknown_robot", 40}};
  const ServerStatus st2 = throughEnvelope(st);
  ASSERT_EQ(st2.rejects.size(), 3u);
  for (size_t i = 0; i < st.rejects.size(); ++i) {
    EXPECT_EQ(st2.rejects[i].robot_id, st.rejects[i].robot_id);
    EXPECT_EQ(st2.rejects[i].reason, st.rejects[i].reason);
    EXPECT_EQ(st2.rejects[i].count, st.rejects[i].count);
  }
  EXPECT_EQ(throughEnvelope(testing::sampleStatus()).rejects.size(), 0u);
}

TEST(ProtoRoundTrip, EmptyCollections) {
  Keyframe k = testing::sampleKeyframe(0);
  k.images = testing::sampleImages(16, 8, 0, ColorCodec::kNone);
  k.previous_keyframe_id = -1;
  expectKeyframe(k, throughEnvelope(k));
  PoseCorrections c = testing::sampleCorrections();
  c.keyframes.clear();
  EXPECT_TRUE(throughEnvelope(c).keyframes.empty());
}

TEST(ProtoRoundTrip, LoopEdges) {
  const LoopEdges m = testing::sampleLoops(), m2 = throughEnvelope(m);
  EXPECT_EQ(m2.robot_id, m.robot_id);
  EXPECT_EQ(m2.graph_revision, m.graph_revision);
  ASSERT_EQ(m2.edges.size(), m.edges.size());
  for (size_t i = 0; i < m.edges.size(); ++i) {
    EXPECT_EQ(m2.edges[i].robot_from, m.edges[i].robot_from);
    EXPECT_EQ(m2.edges[i].keyframe_from, m.edges[i].keyframe_from);
    EXPECT_EQ(m2.edges[i].robot_to, m.edges[i].robot_to);
    EXPECT_EQ(m2.edges[i].keyframe_to, m.edges[i].keyframe_to);
    EXPECT_EQ(m2.edges[i].inter_robot, m.edges[i].inter_robot);
    EXPECT_EQ(m2.edges[i].p_from, m.edges[i].p_from);
    EXPECT_EQ(m2.edges[i].p_to, m.edges[i].p_to);
  }
  LoopEdges bad = m;
  bad.edges[1].p_to.x() = std::nan("");
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.edges[0].robot_to = "bad id";
  EXPECT_FALSE(validate(bad));
  EXPECT_EQ(channelFor(MessageType::kLoopEdges, "robot_1").value(), "rgbdmap/robot_1/loops");
  EXPECT_EQ(directionOf(MessageType::kLoopEdges), Direction::kServerToRobot);
}

TEST(ProtoRoundTrip, HelloCameraMount) {
  Hello h = testing::sampleHello();
  EXPECT_TRUE(testing::sampleHello().T_base_camera.isApprox(throughEnvelope(h).T_base_camera, 1e-12));
  h.T_base_camera = SE3::Identity();
  EXPECT_TRUE(throughEnvelope(h).T_base_camera.isApprox(SE3::Identity()));
  const Hello fresh;
  EXPECT_TRUE(fresh.T_base_camera.isApprox(defaultT_base_camera()));
  h.T_base_camera.translation() = Vec3(0, 0, kMaxCameraOffsetM + 1.0);
  EXPECT_FALSE(validate(h));
  h.T_base_camera = SE3::Identity();
  h.T_base_camera.linear()(0, 0) = 2.0;  // not a rotation
  EXPECT_FALSE(validate(h));
  h.T_base_camera.translation().x() = std::nan("");
  EXPECT_FALSE(encodePayload(h));
}

TEST(ProtoRoundTrip, RobotPose) {
  const RobotPose m = testing::sampleRobotPose(), m2 = throughEnvelope(m);
  EXPECT_EQ(m2.robot_id, m.robot_id);
  EXPECT_EQ(m2.timestamp, m.timestamp);
  EXPECT_EQ(m2.segment_id, m.segment_id);
  EXPECT_EQ(m2.reference_keyframe_id, m.reference_keyframe_id);
  EXPECT_EQ(m2.tracking_state, m.tracking_state);
  EXPECT_EQ(m2.graph_revision, m.graph_revision);
  expectPose(m2.T_map_cam, m.T_map_cam);
  RobotPose bad = m;
  bad.header.sender = "robot_2";  // a robot's pose comes from that robot only
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.tracking_state = 4;
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.graph_revision = -2;
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.timestamp = std::nan("");
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.T_map_cam.translation().y() = INFINITY;
  EXPECT_FALSE(validate(bad));
  EXPECT_EQ(channelFor(MessageType::kRobotPose, "robot_1").value(), "rgbdmap/robot_1/pose");
  EXPECT_EQ(directionOf(MessageType::kRobotPose), Direction::kRobotToServer);
}

TEST(ProtoRoundTrip, LinkStatus) {
  const LinkStatus m = testing::sampleLinkStatus(), m2 = throughEnvelope(m);
  EXPECT_EQ(m2.robot_id, m.robot_id);
  EXPECT_EQ(m2.keyframes_made, m.keyframes_made);
  EXPECT_EQ(m2.keyframes_acked, m.keyframes_acked);
  EXPECT_EQ(m2.in_flight, m.in_flight);
  EXPECT_EQ(m2.queued, m.queued);
  EXPECT_EQ(m2.spool_depth, m.spool_depth);
  EXPECT_EQ(m2.spool_bytes, m.spool_bytes);
  EXPECT_EQ(m2.oldest_unanswered_s, m.oldest_unanswered_s);
  EXPECT_EQ(m2.live_only, m.live_only);
  EXPECT_EQ(m2.diagnosis, m.diagnosis);
  LinkStatus bad = m;
  bad.header.sender = "robot_2";  // a robot's link status comes from that robot only
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.spool_depth = -2;
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.queued = -1;
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.oldest_unanswered_s = std::nan("");
  EXPECT_FALSE(validate(bad));
  bad = m;
  bad.diagnosis = "bell\a";
  EXPECT_FALSE(validate(bad));
  EXPECT_EQ(channelFor(MessageType::kLinkStatus, "robot_1").value(), "rgbdmap/robot_1/link");
  EXPECT_EQ(directionOf(MessageType::kLinkStatus), Direction::kRobotToServer);
}

TEST(ProtoChannels, NamesAndDirections) {
  EXPECT_EQ(channelFor(MessageType::kKeyframe, "robot_1").value(), "rgbdmap/robot_1/keyframe");
  EXPECT_EQ(channelFor(MessageType::kPoseCorrections, "r2").value(), "rgbdmap/r2/pose_corrections");
  // Map and status go to each robot on its own channel, signed with its key (a shared channel would keep
  // only the copy signed for the last robot as the "latest" for late joiners).
  EXPECT_EQ(channelFor(MessageType::kServerStatus, "x").value(), "rgbdmap/x/status");
  EXPECT_EQ(channelFor(MessageType::kMapUpdate, "x").value(), "rgbdmap/x/map");
  EXPECT_FALSE(channelFor(MessageType::kKeyframe, "bad/id"));
  EXPECT_FALSE(channelFor(MessageType::kKeyframe, "server"));
  EXPECT_EQ(directionOf(MessageType::kVelocityCommand), Direction::kServerToRobot);
  for (int t = 1; t <= kNumMessageTypes; ++t)
    EXPECT_NE(std::string(channelSuffix(static_cast<MessageType>(t))), "unknown");
}

TEST(ProtoChannels, SplitChannel) {
  std::string robot, suffix;
  ASSERT_TRUE(splitChannel("rgbdmap/robot_1/keyframe", &robot, &suffix));
  EXPECT_EQ(robot, "robot_1");
  EXPECT_EQ(suffix, "keyframe");
  ASSERT_TRUE(splitChannel("rgbdmap/r/a/b", &robot, &suffix));
  EXPECT_EQ(suffix, "a/b");
  for (const char* bad : {"", "rgbdmap/", "rgbdmap/r", "rgbdmap//keyframe", "rgbdmap/r/", "other/r/keyframe"})
    EXPECT_FALSE(splitChannel(bad, &robot, &suffix)) << bad;
}

// Map stores and bundles hold Keyframe messages only, and this build reads those of every schema from
// kOldestStoredSchemaVersion on (store_files.cpp, map_bundle.cpp). That holds while keyframe_t, with every
// type it includes, is the one of that schema: its LCM hash is the one schema 3 had. A change of keyframe_t
// fails here; then kOldestStoredSchemaVersion becomes the new schema (older stores are refused).
TEST(ProtoSchema, KeyframeMessageIsTheOneOfTheOldestReadableStoredSchema) {
  EXPECT_EQ(kOldestStoredSchemaVersion, 3);
  EXPECT_EQ(static_cast<uint64_t>(rgbdmap_lcm::keyframe_t::getHash()), 0x6cf1992554610e03ull);
}

}  // namespace
}  // namespace rgbdmap::msg
