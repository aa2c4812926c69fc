// Each invalid message is rejected with the expected reason, on decode (crafted wire bytes) and on encode.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/proto/map_payload.hpp"
#include "rgbdmap/proto/validate.hpp"
#include "rgbdmap_lcm/keyframe_t.hpp"
#include "rgbdmap_lcm/occupancy_slice_t.hpp"

namespace rgbdmap::msg {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Header robotHeader() { return Header{kSchemaVersion, "robot_1", 1, 0, 1}; }
Header serverHeader() { return Header{kSchemaVersion, kServerId, 1, 0, 1}; }

template <typename W>
Bytes encodeWire(const W& w) {
  Bytes out(static_cast<size_t>(w.getEncodedSize()));
  w.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

/// A valid keyframe in wire form, to be broken one field at a time.
rgbdmap_lcm::keyframe_t wireKeyframe() {
  Keyframe k = testing::sampleKeyframe(10);
  k.header = robotHeader();
  const Bytes b = encodePayload(k).value();
  rgbdmap_lcm::keyframe_t w;
  EXPECT_EQ(w.decode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return w;
}

std::string decodeError(const rgbdmap_lcm::keyframe_t& w) {
  Result<Keyframe> r = decodePayload<Keyframe>(encodeWire(w));
  return r ? "accepted" : r.error();
}

TEST(MessageValidation, KeyframeWireFields) {
  EXPECT_EQ(decodeError(wireKeyframe()), "accepted");
  auto w = wireKeyframe();
  w.T_odom_cam.q[3] *= 1.01;
  EXPECT_EQ(decodeError(w), "T_odom_cam: non-unit quaternion");
  w = wireKeyframe();
  w.T_odom_cam.q[0] += 1e-9;  // within tolerance: normalised and accepted
  EXPECT_EQ(decodeError(w), "accepted");
  w = wireKeyframe();
  w.T_prev_cur.t[1] = kNaN;
  EXPECT_EQ(decodeError(w), "T_prev_cur: non-finite translation");
  w = wireKeyframe();
  w.descriptors.pop_back();
  w.num_descriptor_bytes -= 1;
  EXPECT_EQ(decodeError(w), "descriptor bytes != keypoints * 32");
  w = wireKeyframe();
  w.keypoints.pop_back();
  w.num_keypoints -= 1;
  EXPECT_EQ(decodeError(w), "descriptor bytes != keypoints * 32");
  w = wireKeyframe();
  w.keypoints[3].u = 1e6f;
  EXPECT_EQ(decodeError(w), "keypoint outside the image");
  w = wireKeyframe();
  w.keypoints[3].depth_m = std::nanf("");
  EXPECT_EQ(decodeError(w), "keypoint depth out of range");
  w = wireKeyframe();
  w.information[0] = -5.0;
  EXPECT_EQ(decodeError(w), "information not positive semi-definite");
  w = wireKeyframe();
  w.information[4] = kNaN;
  EXPECT_EQ(decodeError(w), "information not finite");
  w = wireKeyframe();
  w.image_width += 1;
  EXPECT_EQ(decodeError(w), "depth blob header does not match the image size");
  w = wireKeyframe();
  w.color_codec = 9;
  EXPECT_EQ(decodeError(w), "unknown colour codec");
  w = wireKeyframe();
  w.keyframe_id = -3;
  EXPECT_EQ(decodeError(w), "negative id");
  w = wireKeyframe();
  w.robot_id = "robot/1";
  EXPECT_EQ(decodeError(w), "invalid robot id");
  w = wireKeyframe();
  w.robot_id = "robot_2";
  EXPECT_EQ(decodeError(w), "sender is not the robot");
  w = wireKeyframe();
  w.header.schema_version = 7;
  EXPECT_EQ(decodeError(w), "wrong schema version");
  w = wireKeyframe();
  w.timestamp = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(decodeError(w), "invalid timestamp");
}

void putBigEndian32(Bytes& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>(v >> (24 - 8 * i));
}

TEST(MessageValidation, KeyframeCountsThatDoNotFitTheBytes) {
  const rgbdmap_lcm::keyframe_t w = wireKeyframe();
  const Bytes good = encodeWire(w);
  // Offset of num_keypoints: hash, header, robot_id, segment, id, timestamp, pose, previous id, pose, info.
  const size_t at =
      8 + w.header._getEncodedSizeNoHash() + 4 + w.robot_id.size() + 1 + 4 + 4 + 8 + 56 + 4 + 56 + 21 * 8;
  ASSERT_EQ(good[at + 3], 10);  // the sample has 10 keypoints
  // Forged counts must fail without allocating: the hardened decoder bounds each count by the bytes left.
  for (uint32_t forged : {0x7fffffffu, 0x80000000u, 0xffffffffu, 11u, 9u, 0u}) {
    Bytes b = good;
    putBigEndian32(b, at, forged);
    Result<Keyframe> r = decodePayload<Keyframe>(b);
    EXPECT_FALSE(r) << forged;
  }
  EXPECT_EQ(decodePayload<Keyframe>(Bytes(good.begin(), good.end() - 1)).error(),
            "truncated or wrong type: LCM decode failed");
  Bytes longer = good;
  longer.push_back(0);
  EXPECT_EQ(decodePayload<Keyframe>(longer).error(), "malformed: trailing bytes");
  EXPECT_EQ(decodePayload<Heartbeat>(good).error(), "truncated or wrong type: LCM decode failed");
}

TEST(MessageValidation, ServerMessages) {
  OccupancySlice s = testing::sampleSlice();
  s.header = serverHeader();
  s.cells.pop_back();
  EXPECT_EQ(encodePayload(s).error(), "cell count != width * height");
  s = testing::sampleSlice();
  s.header = serverHeader();
  s.cells[5] = 101;
  EXPECT_EQ(encodePayload(s).error(), "cell value out of range");
  s.cells[5] = 0;
  s.z_min_m = 3.0f;
  EXPECT_EQ(encodePayload(s).error(), "invalid height band");
  s.z_min_m = 0.0f;
  s.header.sender = "robot_1";
  EXPECT_EQ(encodePayload(s).error(), "sender is not the server");

  VelocityCommand v = testing::sampleVelocity();
  v.header = serverHeader();
  v.linear_mps.x() = 50.0;
  EXPECT_EQ(encodePayload(v).error(), "velocity out of range");
  v.linear_mps.x() = kNaN;
  EXPECT_EQ(encodePayload(v).error(), "velocity out of range");
  v.linear_mps.x() = 0.2;
  v.header.sender = v.robot_id;
  EXPECT_TRUE(encodePayload(v)) << "a robot may command itself (its on-board avoidance)";
  v.header.sender = v.robot_id + "x";
  EXPECT_EQ(encodePayload(v).error(), "sender is neither the server nor the commanded robot");

  PoseCorrections c = testing::sampleCorrections();
  c.header = serverHeader();
  c.keyframes[3].T_map_cam.linear()(0, 0) = 2.0;
  EXPECT_EQ(encodePayload(c).error(), "invalid pose");

  ServerStatus st = testing::sampleStatus();
  st.header = serverHeader();
  st.robots[0].robot_id = "server";
  EXPECT_EQ(encodePayload(st).error(), "invalid robot id");
  st = testing::sampleStatus();
  st.header = serverHeader();
  st.rejects = {{"", "unknown_robot", 1}};
  EXPECT_TRUE(encodePayload(st)) << "\"\" is the unknown bucket";
  st.rejects[0].reason = "bad signature";
  EXPECT_EQ(encodePayload(st).error(), "invalid reject reason");
  st.rejects[0] = {"robot 1", "bad_signature", 1};
  EXPECT_EQ(encodePayload(st).error(), "invalid robot id");
  st.rejects[0] = {"robot_1", "bad_signature", -1};
  EXPECT_EQ(encodePayload(st).error(), "negative count");
  st.rejects.assign(kMaxRejectCounts + 1, RejectCount{"robot_1", "malformed", 1});
  EXPECT_EQ(encodePayload(st).error(), "too many reject counts");
  KeyframeAck a = testing::sampleAck();
  a.header = serverHeader();
  a.reason = "bad\nline";
  EXPECT_EQ(encodePayload(a).error(), "invalid reason text");
}

TEST(MessageValidation, MapDecompressedLength) {
  MapUpdate m = testing::sampleMap();
  m.header = serverHeader();
  ASSERT_TRUE(encodePayload(m));
  m.raw_size += 1;
  EXPECT_EQ(mapBytes(m).error(), "decompressed length != raw size");
  m.raw_size -= 1;
  m.data.push_back(0);
  EXPECT_EQ(mapBytes(m).error(), "map data is not exactly one zstd frame");
  m.data = {1, 2, 3};
  EXPECT_EQ(mapBytes(m).error(), "map data is not a zstd frame with a content size");
  MapUpdate raw;
  raw.header = serverHeader();
  ASSERT_TRUE(setMapBytes(Bytes(10, 7), MapCompression::kNone, &raw));
  EXPECT_EQ(mapBytes(raw).value(), Bytes(10, 7));
  raw.raw_size = 11;
  EXPECT_EQ(encodePayload(raw).error(), "map data size != raw size");
}

TEST(MessageValidation, HelloAndIds) {
  Hello h = testing::sampleHello();
  h.header = robotHeader();
  h.camera.fx = -1.0;
  EXPECT_EQ(encodePayload(h).error().rfind("camera: ", 0), 0u);
  for (const double readout : {-0.001, 0.2, std::nan("")}) {
    h = testing::sampleHello();
    h.header = robotHeader();
    h.camera.readout_s = readout;
    ASSERT_FALSE(encodePayload(h)) << readout;
    EXPECT_NE(encodePayload(h).error().find("readout_s"), std::string::npos) << encodePayload(h).error();
  }
  h = testing::sampleHello();
  h.header = robotHeader();
  h.capabilities.push_back("has space");
  EXPECT_EQ(encodePayload(h).error(), "invalid capability name");
  EXPECT_TRUE(isRobotId("robot-1_A"));
  EXPECT_FALSE(isRobotId(std::string(33, 'a')));
  EXPECT_FALSE(isRobotId(""));
  EXPECT_FALSE(isRobotId("server"));
  EXPECT_FALSE(isValidId(std::string("a\0b", 3)));
}

}  // namespace
}  // namespace rgbdmap::msg
