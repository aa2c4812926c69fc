// Wire <-> internal for the robot's messages: Hello, Heartbeat, RobotPose, LinkStatus, Keyframe.
#include <cmath>

#include "convert_common.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap_lcm/heartbeat_t.hpp"
#include "rgbdmap_lcm/hello_t.hpp"
#include "rgbdmap_lcm/keyframe_t.hpp"
#include "rgbdmap_lcm/link_status_t.hpp"
#include "rgbdmap_lcm/robot_pose_t.hpp"

namespace rgbdmap::msg {
namespace {

using detail::fromWire;
using detail::toWire;

rgbdmap_lcm::hello_t toWireHello(const Hello& m) {
  rgbdmap_lcm::hello_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  const CameraIntrinsics& k = m.camera;
  w.camera = rgbdmap_lcm::camera_t{};
  w.camera.fx = k.fx, w.camera.fy = k.fy, w.camera.cx = k.cx, w.camera.cy = k.cy;
  w.camera.width = k.width, w.camera.height = k.height, w.camera.depth_scale = k.depth_scale;
  w.camera.readout_s = k.readout_s;
  for (int i = 0; i < 5; ++i) w.camera.distortion[i] = k.distortion[i];
  w.T_base_camera = toWire(m.T_base_camera);
  w.software_version = m.software_version;
  w.num_capabilities = static_cast<int16_t>(m.capabilities.size());
  w.capabilities = m.capabilities;
  return w;
}

Result<Hello> fromWireHello(const rgbdmap_lcm::hello_t& w) {
  Hello m;
  m.header = fromWire(w.header);
  m.robot_id = w.robot_id;
  CameraIntrinsics& k = m.camera;
  k.fx = w.camera.fx, k.fy = w.camera.fy, k.cx = w.camera.cx, k.cy = w.camera.cy;
  k.width = w.camera.width, k.height = w.camera.height, k.depth_scale = w.camera.depth_scale;
  k.readout_s = w.camera.readout_s;
  for (int i = 0; i < 5; ++i) k.distortion[i] = w.camera.distortion[i];
  Result<SE3> T_base_camera = fromWire(w.T_base_camera, "T_base_camera");
  if (!T_base_camera) return Result<Hello>::failure(T_base_camera.error());
  m.T_base_camera = *T_base_camera;
  m.software_version = w.software_version;
  m.capabilities = w.capabilities;
  return m;
}

rgbdmap_lcm::heartbeat_t toWireHeartbeat(const Heartbeat& m) {
  rgbdmap_lcm::heartbeat_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.last_keyframe_id = m.last_keyframe_id;
  w.segment_id = m.segment_id;
  w.tracking_state = static_cast<int8_t>(m.tracking_state);
  w.uptime_s = m.uptime_s;
  return w;
}

Result<Heartbeat> fromWireHeartbeat(const rgbdmap_lcm::heartbeat_t& w) {
  return Heartbeat{fromWire(w.header), w.robot_id,       w.last_keyframe_id,
                   w.segment_id,       w.tracking_state, w.uptime_s};
}

rgbdmap_lcm::robot_pose_t toWireRobotPose(const RobotPose& m) {
  rgbdmap_lcm::robot_pose_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.timestamp = m.timestamp;
  w.segment_id = m.segment_id;
  w.reference_keyframe_id = m.reference_keyframe_id;
  w.tracking_state = static_cast<int8_t>(m.tracking_state);
  w.graph_revision = m.graph_revision;
  w.T_map_cam = toWire(m.T_map_cam);
  return w;
}

Result<RobotPose> fromWireRobotPose(const rgbdmap_lcm::robot_pose_t& w) {
  RobotPose m;
  m.header = fromWire(w.header);
  m.robot_id = w.robot_id;
  m.timestamp = w.timestamp;
  m.segment_id = w.segment_id;
  m.reference_keyframe_id = w.reference_keyframe_id;
  m.tracking_state = w.tracking_state;
  m.graph_revision = w.graph_revision;
  Result<SE3> T_map_cam = fromWire(w.T_map_cam, "T_map_cam");
  if (!T_map_cam) return Result<RobotPose>::failure(T_map_cam.error());
  m.T_map_cam = *T_map_cam;
  return m;
}

rgbdmap_lcm::link_status_t toWireLinkStatus(const LinkStatus& m) {
  rgbdmap_lcm::link_status_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.keyframes_made = m.keyframes_made;
  w.keyframes_acked = m.keyframes_acked;
  w.in_flight = m.in_flight;
  w.queued = m.queued;
  w.spool_depth = m.spool_depth;
  w.spool_bytes = m.spool_bytes;
  w.oldest_unanswered_s = m.oldest_unanswered_s;
  w.live_only = m.live_only ? 1 : 0;
  w.diagnosis = m.diagnosis;
  return w;
}

Result<LinkStatus> fromWireLinkStatus(const rgbdmap_lcm::link_status_t& w) {
  if (w.live_only != 0 && w.live_only != 1) return Result<LinkStatus>::failure("live_only is not 0 or 1");
  return LinkStatus{fromWire(w.header),    w.robot_id,       w.keyframes_made, w.keyframes_acked,
                    w.in_flight,           w.queued,         w.spool_depth,    w.spool_bytes,
                    w.oldest_unanswered_s, w.live_only == 1, w.diagnosis};
}

void informationToWire(const Mat6& info, double* out) {
  int n = 0;
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) out[n++] = info(r, c);
}

Mat6 informationFromWire(const double* in) {
  Mat6 info;
  int n = 0;
  for (int r = 0; r < 6; ++r)
    for (int c = r; c < 6; ++c) info(r, c) = info(c, r) = in[n++];
  return info;
}

rgbdmap_lcm::keyframe_t toWireKeyframe(const Keyframe& m) {
  rgbdmap_lcm::keyframe_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.segment_id = m.segment_id;
  w.keyframe_id = m.keyframe_id;
  w.timestamp = m.timestamp;
  w.T_odom_cam = toWire(m.T_odom_cam);
  w.previous_keyframe_id = m.previous_keyframe_id;
  w.T_prev_cur = toWire(m.T_prev_cur);
  informationToWire(m.information, w.information);
  w.num_keypoints = detail::count(m.keypoints);
  w.keypoints.resize(m.keypoints.size());
  for (size_t i = 0; i < m.keypoints.size(); ++i) {
    const KeyPoint& k = m.keypoints[i];
    w.keypoints[i] = rgbdmap_lcm::keypoint_t{};
    w.keypoints[i].u = k.u, w.keypoints[i].v = k.v, w.keypoints[i].octave = static_cast<int8_t>(k.octave);
    w.keypoints[i].angle_deg = k.angle_deg, w.keypoints[i].response = k.response;
    w.keypoints[i].depth_m = k.depth_m;
  }
  w.num_descriptor_bytes = detail::count(m.descriptors);
  w.descriptors = m.descriptors;
  w.image_width = static_cast<int16_t>(m.images.width);
  w.image_height = static_cast<int16_t>(m.images.height);
  w.color_codec = static_cast<int8_t>(m.images.color_codec);
  w.depth_size = detail::count(m.images.depth);
  w.depth = m.images.depth;
  w.color_size = detail::count(m.images.color);
  w.color = m.images.color;
  return w;
}

Result<Keyframe> fromWireKeyframe(const rgbdmap_lcm::keyframe_t& w) {
  Keyframe m;
  m.header = fromWire(w.header);
  m.robot_id = w.robot_id;
  m.segment_id = w.segment_id;
  m.keyframe_id = w.keyframe_id;
  m.timestamp = w.timestamp;
  Result<SE3> T_odom_cam = fromWire(w.T_odom_cam, "T_odom_cam");
  if (!T_odom_cam) return Result<Keyframe>::failure(T_odom_cam.error());
  m.T_odom_cam = *T_odom_cam;
  m.previous_keyframe_id = w.previous_keyframe_id;
  Result<SE3> T_prev_cur = fromWire(w.T_prev_cur, "T_prev_cur");
  if (!T_prev_cur) return Result<Keyframe>::failure(T_prev_cur.error());
  m.T_prev_cur = *T_prev_cur;
  m.information = informationFromWire(w.information);
  m.keypoints.reserve(w.keypoints.size());
  for (const rgbdmap_lcm::keypoint_t& k : w.keypoints)
    m.keypoints.push_back(KeyPoint{k.u, k.v, k.octave, k.angle_deg, k.response, k.depth_m});
  m.descriptors = w.descriptors;
  if (w.image_width < 0 || w.image_height < 0) return Result<Keyframe>::failure("negative image size");
  m.images.width = static_cast<uint16_t>(w.image_width);
  m.images.height = static_cast<uint16_t>(w.image_height);
  if (w.color_codec < 0 || w.color_codec > static_cast<int>(ColorCodec::kLossless))
    return Result<Keyframe>::failure("unknown colour codec");
  m.images.color_codec = static_cast<ColorCodec>(w.color_codec);
  m.images.depth = w.depth;
  m.images.color = w.color;
  return m;
}

}  // namespace

RGBDMAP_PROTO_CODEC(Hello, toWireHello, fromWireHello)
RGBDMAP_PROTO_CODEC(Heartbeat, toWireHeartbeat, fromWireHeartbeat)
RGBDMAP_PROTO_CODEC(RobotPose, toWireRobotPose, fromWireRobotPose)
RGBDMAP_PROTO_CODEC(LinkStatus, toWireLinkStatus, fromWireLinkStatus)
RGBDMAP_PROTO_CODEC(Keyframe, toWireKeyframe, fromWireKeyframe)

Result<DecodedImages> decodeKeyframeImages(const Keyframe& keyframe) { return decodeImages(keyframe.images); }

}  // namespace rgbdmap::msg
