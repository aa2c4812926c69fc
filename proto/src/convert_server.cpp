// Wire <-> internal for the server's messages: KeyframeAck, PoseCorrections, LoopEdges, OccupancySlice,
// MapUpdate, VelocityCommand, ServerStatus.
#include <cmath>

#include "convert_common.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap_lcm/keyframe_ack_t.hpp"
#include "rgbdmap_lcm/loop_edges_t.hpp"
#include "rgbdmap_lcm/map_update_t.hpp"
#include "rgbdmap_lcm/occupancy_slice_t.hpp"
#include "rgbdmap_lcm/pose_corrections_t.hpp"
#include "rgbdmap_lcm/server_status_t.hpp"
#include "rgbdmap_lcm/velocity_command_t.hpp"

namespace rgbdmap::msg {
namespace {

using detail::fromWire;
using detail::toWire;

rgbdmap_lcm::keyframe_ack_t toWireAck(const KeyframeAck& m) {
  rgbdmap_lcm::keyframe_ack_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.keyframe_id = m.keyframe_id;
  w.accepted = m.accepted;
  w.reason = m.reason;
  return w;
}

Result<KeyframeAck> fromWireAck(const rgbdmap_lcm::keyframe_ack_t& w) {
  return KeyframeAck{fromWire(w.header), w.robot_id, w.keyframe_id, w.accepted != 0, w.reason};
}

rgbdmap_lcm::pose_corrections_t toWireCorrections(const PoseCorrections& m) {
  rgbdmap_lcm::pose_corrections_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.graph_revision = m.graph_revision;
  w.T_map_odom = toWire(m.T_map_odom);
  w.num_keyframes = detail::count(m.keyframes);
  w.keyframes.resize(m.keyframes.size());
  for (size_t i = 0; i < m.keyframes.size(); ++i) {
    w.keyframes[i].keyframe_id = m.keyframes[i].keyframe_id;
    w.keyframes[i].T_map_cam = toWire(m.keyframes[i].T_map_cam);
  }
  return w;
}

Result<PoseCorrections> fromWireCorrections(const rgbdmap_lcm::pose_corrections_t& w) {
  using R = Result<PoseCorrections>;
  PoseCorrections m;
  m.header = fromWire(w.header);
  m.robot_id = w.robot_id;
  m.graph_revision = w.graph_revision;
  Result<SE3> T_map_odom = fromWire(w.T_map_odom, "T_map_odom");
  if (!T_map_odom) return R::failure(T_map_odom.error());
  m.T_map_odom = *T_map_odom;
  m.keyframes.reserve(w.keyframes.size());
  for (const rgbdmap_lcm::corrected_pose_t& k : w.keyframes) {
    Result<SE3> T = fromWire(k.T_map_cam, "T_map_cam");
    if (!T) return R::failure(T.error());
    m.keyframes.push_back(CorrectedPose{k.keyframe_id, *T});
  }
  return m;
}

rgbdmap_lcm::loop_edges_t toWireLoops(const LoopEdges& m) {
  rgbdmap_lcm::loop_edges_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.graph_revision = m.graph_revision;
  w.num_edges = detail::count(m.edges);
  w.edges.resize(m.edges.size());
  for (size_t i = 0; i < m.edges.size(); ++i) {
    const MapLoopEdge& e = m.edges[i];
    rgbdmap_lcm::loop_edge_t& o = w.edges[i];
    o.robot_from = e.robot_from;
    o.keyframe_from = e.keyframe_from;
    o.robot_to = e.robot_to;
    o.keyframe_to = e.keyframe_to;
    o.inter_robot = e.inter_robot;
    for (int a = 0; a < 3; ++a) {
      o.p_from[a] = e.p_from[a];
      o.p_to[a] = e.p_to[a];
    }
  }
  return w;
}

Result<LoopEdges> fromWireLoops(const rgbdmap_lcm::loop_edges_t& w) {
  LoopEdges m;
  m.header = fromWire(w.header);
  m.robot_id = w.robot_id;
  m.graph_revision = w.graph_revision;
  m.edges.reserve(w.edges.size());
  for (const rgbdmap_lcm::loop_edge_t& o : w.edges)
    m.edges.push_back(MapLoopEdge{o.robot_from, o.keyframe_from, o.robot_to, o.keyframe_to,
                                  o.inter_robot != 0, Vec3(o.p_from[0], o.p_from[1], o.p_from[2]),
                                  Vec3(o.p_to[0], o.p_to[1], o.p_to[2])});
  return m;
}

rgbdmap_lcm::occupancy_slice_t toWireSlice(const OccupancySlice& m) {
  rgbdmap_lcm::occupancy_slice_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.T_map_grid = toWire(m.T_map_grid);
  w.resolution_m = m.resolution_m;
  w.width = m.width;
  w.height = m.height;
  w.z_min_m = m.z_min_m;
  w.z_max_m = m.z_max_m;
  w.num_cells = detail::count(m.cells);
  w.cells = m.cells;
  return w;
}

Result<OccupancySlice> fromWireSlice(const rgbdmap_lcm::occupancy_slice_t& w) {
  Result<SE3> T_map_grid = fromWire(w.T_map_grid, "T_map_grid");
  if (!T_map_grid) return Result<OccupancySlice>::failure(T_map_grid.error());
  return OccupancySlice{fromWire(w.header), w.robot_id, *T_map_grid, w.resolution_m, w.width,
                        w.height,           w.z_min_m,  w.z_max_m,   w.cells};
}

rgbdmap_lcm::map_update_t toWireMap(const MapUpdate& m) {
  rgbdmap_lcm::map_update_t w;
  w.header = toWire(m.header);
  w.map_revision = m.map_revision;
  w.resolution_m = m.resolution_m;
  w.full = m.full;
  w.compression = static_cast<int8_t>(m.compression);
  w.raw_size = m.raw_size;
  w.robot_keyframe_id = m.robot_keyframe_id;
  w.data_size = detail::count(m.data);
  w.data = m.data;
  return w;
}

Result<MapUpdate> fromWireMap(const rgbdmap_lcm::map_update_t& w) {
  if (w.compression < 0 || w.compression > static_cast<int>(MapCompression::kZstd))
    return Result<MapUpdate>::failure("unknown map compression");
  return MapUpdate{fromWire(w.header),
                   w.map_revision,
                   w.resolution_m,
                   w.full != 0,
                   static_cast<MapCompression>(w.compression),
                   w.raw_size,
                   w.data,
                   w.robot_keyframe_id};
}

rgbdmap_lcm::velocity_command_t toWireVelocity(const VelocityCommand& m) {
  rgbdmap_lcm::velocity_command_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  for (int i = 0; i < 3; ++i) w.linear_mps[i] = m.linear_mps[i], w.angular_radps[i] = m.angular_radps[i];
  w.duration_s = m.duration_s;
  return w;
}

Result<VelocityCommand> fromWireVelocity(const rgbdmap_lcm::velocity_command_t& w) {
  const Vec3 linear(w.linear_mps[0], w.linear_mps[1], w.linear_mps[2]);
  const Vec3 angular(w.angular_radps[0], w.angular_radps[1], w.angular_radps[2]);
  return VelocityCommand{fromWire(w.header), w.robot_id, linear, angular, w.duration_s};
}

rgbdmap_lcm::server_status_t toWireStatus(const ServerStatus& m) {
  rgbdmap_lcm::server_status_t w;
  w.header = toWire(m.header);
  w.state = m.state;
  w.uptime_s = m.uptime_s;
  w.graph_revision = m.graph_revision;
  w.map_revision = m.map_revision;
  w.num_robots = detail::count(m.robots);
  w.robots.resize(m.robots.size());
  for (size_t i = 0; i < m.robots.size(); ++i) {
    const RobotStatus& r = m.robots[i];
    w.robots[i].robot_id = r.robot_id;
    w.robots[i].keyframes = r.keyframes;
    w.robots[i].loop_closures = r.loop_closures;
    w.robots[i].rejected_messages = r.rejected_messages;
    w.robots[i].last_utime = r.last_utime;
    w.robots[i].localize = r.localize;
    w.robots[i].placed = r.placed;
  }
  w.num_rejects = detail::count(m.rejects);
  w.rejects.resize(m.rejects.size());
  for (size_t i = 0; i < m.rejects.size(); ++i) {
    w.rejects[i].robot_id = m.rejects[i].robot_id;
    w.rejects[i].reason = m.rejects[i].reason;
    w.rejects[i].count = m.rejects[i].count;
  }
  return w;
}

Result<ServerStatus> fromWireStatus(const rgbdmap_lcm::server_status_t& w) {
  ServerStatus m{fromWire(w.header), w.state, w.uptime_s, w.graph_revision, w.map_revision, {}, {}};
  m.robots.reserve(w.robots.size());
  for (const rgbdmap_lcm::robot_status_t& r : w.robots)
    m.robots.push_back(RobotStatus{r.robot_id, r.keyframes, r.loop_closures, r.rejected_messages,
                                   r.last_utime, r.localize != 0, r.placed != 0});
  m.rejects.reserve(w.rejects.size());
  for (const rgbdmap_lcm::reject_count_t& r : w.rejects)
    m.rejects.push_back(RejectCount{r.robot_id, r.reason, r.count});
  return m;
}

}  // namespace

RGBDMAP_PROTO_CODEC(KeyframeAck, toWireAck, fromWireAck)
RGBDMAP_PROTO_CODEC(PoseCorrections, toWireCorrections, fromWireCorrections)
RGBDMAP_PROTO_CODEC(LoopEdges, toWireLoops, fromWireLoops)
RGBDMAP_PROTO_CODEC(OccupancySlice, toWireSlice, fromWireSlice)
RGBDMAP_PROTO_CODEC(MapUpdate, toWireMap, fromWireMap)
RGBDMAP_PROTO_CODEC(VelocityCommand, toWireVelocity, fromWireVelocity)
RGBDMAP_PROTO_CODEC(ServerStatus, toWireStatus, fromWireStatus)

}  // namespace rgbdmap::msg
