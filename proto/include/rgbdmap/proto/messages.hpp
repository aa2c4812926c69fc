#pragma once
// Internal message structs (namespace rgbdmap::msg): what client and server code reads and writes. The
// wire form is generated from proto/lcm/*.lcm; the one conversion between the two is in proto/src/convert_*.
// Poses are SE3 named by their frames; images stay compressed (rgbdmap/codec/image_codec.hpp blobs).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap::msg {

using Bytes = std::vector<uint8_t>;

/// Bumped whenever any .lcm file changes; a receiver rejects every other version.
/// 2: ServerStatus::rejects; 3: Hello::T_base_camera; 4: RobotStatus::localize, placed; 5: the camera's
/// readout_s.
constexpr int kSchemaVersion = 5;
/// The oldest schema whose stored messages this build reads: a map store or bundle holds only Keyframe
/// messages, and keyframe_t (with what it includes) is the same in schemas 3 to 5.
constexpr int kOldestStoredSchemaVersion = 3;
inline bool isReadableStoredSchema(int version) {
  return version >= kOldestStoredSchemaVersion && version <= kSchemaVersion;
}
/// "3 to 5": the stored schemas this build reads, for error messages.
inline std::string readableStoredSchemas() {
  return std::to_string(kOldestStoredSchemaVersion) + " to " + std::to_string(kSchemaVersion);
}

enum class MessageType : int16_t {
  kHello = 1,
  kHeartbeat = 2,
  kKeyframe = 3,
  kKeyframeAck = 4,
  kPoseCorrections = 5,
  kOccupancySlice = 6,
  kMapUpdate = 7,
  kVelocityCommand = 8,
  kServerStatus = 9,
  kKeyframeChunk = 10,  ///< chunked keyframe transfer (udpm://): see KeyframeChunk, ChunkAck
  kChunkAck = 11,
  kLoopEdges = 12,   ///< the accepted loop edges of a robot's map (visualisers)
  kRobotPose = 13,   ///< a robot's live pose (visualisers)
  kLinkStatus = 14,  ///< a robot's delivery state: spool, window (monitor, visualisers)
};
constexpr int kNumMessageTypes = 14;
const char* toString(MessageType type);
bool isKnownType(int type);

/// Sender id of the mapping server; no robot may use it.
constexpr const char* kServerId = "server";

// Bounds the decoder enforces (the encoder too, so nothing is sent that would be rejected).
constexpr int kMaxIdLength = 32;     ///< robot ids: [A-Za-z0-9_-]{1,32}
constexpr int kMaxTextLength = 256;  ///< free text (versions, reasons, state): printable ASCII
constexpr int kMaxCapabilities = 32;
constexpr int kMaxKeypoints = 10000;
constexpr int kDescriptorBytes = 32;     ///< ORB: 256 bits
constexpr int kMaxCorrections = 100000;  ///< keyframes in one PoseCorrections
constexpr int kMaxLoopEdges = 100000;    ///< edges in one LoopEdges
constexpr int kMaxRobots = 1024;
constexpr int kMaxRejectCounts = 256;  ///< ServerStatus::rejects entries
constexpr int kMaxGridSide = 4096;
constexpr int kMaxMapBytes = 64 << 20;        ///< octree bytes after decompression
constexpr int kMaxEnvelopeBytes = 80 << 20;   ///< one encoded envelope
constexpr double kMaxSpeed = 10.0;            ///< m/s and rad/s, per axis
constexpr double kMaxCommandDuration = 10.0;  ///< s

struct Header {
  int schema_version = kSchemaVersion;
  std::string sender;
  int64_t session = 0;  ///< per process start; see envelope.hpp (ReplayGuard)
  int64_t seq = 0;
  int64_t utime = 0;  ///< microseconds since the Unix epoch
};
bool operator==(const Header& a, const Header& b);

struct Hello {
  static constexpr MessageType kType = MessageType::kHello;
  Header header;
  std::string robot_id;
  CameraIntrinsics camera;
  /// The camera's optical frame in the robot's base frame (REP-103); within kMaxCameraOffsetM of the base.
  SE3 T_base_camera = defaultT_base_camera();
  std::string software_version;
  std::vector<std::string> capabilities;  ///< each like an id: [A-Za-z0-9_-]{1,32}
};
/// A Hello capability: the robot localises in the stored map without changing it (map mode "localize"):
/// its keyframes place and track it and are then dropped, never stored. Without it: map mode "map".
constexpr const char* kCapabilityLocalize = "localize";

struct Heartbeat {
  static constexpr MessageType kType = MessageType::kHeartbeat;
  Header header;
  std::string robot_id;
  int last_keyframe_id = -1;
  int segment_id = 0;
  int tracking_state = 0;  ///< rgbdmap::TrackingState as int, 0..3
  double uptime_s = 0.0;
};

/// Robot -> visualisers, best effort, a few Hz: the robot's current pose as it knows it.
struct RobotPose {
  static constexpr MessageType kType = MessageType::kRobotPose;
  Header header;
  std::string robot_id;
  double timestamp = 0.0;  ///< the frame's (s)
  int segment_id = 0;
  int reference_keyframe_id = -1;
  int tracking_state = 0;           ///< rgbdmap::TrackingState as int, 0..3
  int64_t graph_revision = -1;      ///< of the PoseCorrections applied; -1 before any
  SE3 T_map_cam = SE3::Identity();  ///< T_map_odom(segment) * T_odom_cam
};

/// Robot -> monitor and visualisers, best effort, once a heartbeat period: how its keyframes get through.
struct LinkStatus {
  static constexpr MessageType kType = MessageType::kLinkStatus;
  Header header;
  std::string robot_id;
  int keyframes_made = 0, keyframes_acked = 0;  ///< by this process
  int in_flight = 0, queued = 0;                ///< in the send window; spooled and waiting for it
  int spool_depth = -1;                         ///< spooled and unanswered; -1: no spool
  int64_t spool_bytes = 0;
  double oldest_unanswered_s = 0.0;  ///< the oldest unanswered keyframe's age; 0: none
  bool live_only = false;            ///< the spool refused the last keyframe (budget, disk full)
  std::string diagnosis;             ///< RobotLinkStats::diagnosis
};

struct KeyPoint {
  float u = 0, v = 0;  ///< raw (distorted) pixels
  int octave = 0;      ///< 0..31
  float angle_deg = -1;
  float response = 0;
  float depth_m = 0;  ///< 0 = no depth
};

struct Keyframe {
  static constexpr MessageType kType = MessageType::kKeyframe;
  Header header;
  std::string robot_id;
  int segment_id = 0;
  int keyframe_id = 0;
  double timestamp = 0.0;
  SE3 T_odom_cam = SE3::Identity();
  int previous_keyframe_id = -1;
  SE3 T_prev_cur = SE3::Identity();
  /// Symmetric, positive semi-definite; tangent order (rho, omega), for a right perturbation of T_prev_cur:
  /// T_prev_cur * exp(xi) (equivalently a left perturbation of T_cur_prev, as the odometry computes it).
  Mat6 information = Mat6::Zero();
  std::vector<KeyPoint> keypoints;
  Bytes descriptors;  ///< keypoints.size() * kDescriptorBytes, row i = keypoint i
  EncodedImages images;
};

/// One piece of a signed Keyframe envelope (proto/lcm/keyframe_chunk_t.lcm). validate() checks that the
/// header fields are consistent: count == ceil(total / chunk_bytes), every chunk but the last carries
/// chunk_bytes, the last the rest.
struct KeyframeChunk {
  static constexpr MessageType kType = MessageType::kKeyframeChunk;
  Header header;
  std::string robot_id;
  int64_t transfer_id = 0;
  int keyframe_id = 0;
  int chunk_index = 0;
  int chunk_count = 1;
  int chunk_bytes = 0;
  int total_bytes = 0;
  bool last_of_burst = false;
  Bytes data;
};
constexpr int kMinChunkBytes = 256;
constexpr int kMaxChunkBytes = 60000;
constexpr int kMaxChunkedBytes = 16 << 20;  ///< largest envelope sent in chunks
constexpr int kMaxChunkCount = 65535;

/// Which chunks of one transfer arrived (bit i of received[i / 8], LSB first).
struct ChunkAck {
  static constexpr MessageType kType = MessageType::kChunkAck;
  Header header;
  std::string robot_id;
  int64_t transfer_id = 0;
  int keyframe_id = 0;
  int chunk_count = 1;
  Bytes received;  ///< (chunk_count + 7) / 8 bytes
};

struct KeyframeAck {
  static constexpr MessageType kType = MessageType::kKeyframeAck;
  Header header;
  std::string robot_id;
  int keyframe_id = 0;
  bool accepted = true;
  std::string reason;
};

struct CorrectedPose {
  int keyframe_id = 0;
  SE3 T_map_cam = SE3::Identity();
};

struct PoseCorrections {
  static constexpr MessageType kType = MessageType::kPoseCorrections;
  Header header;
  std::string robot_id;
  int64_t graph_revision = 0;
  SE3 T_map_odom = SE3::Identity();
  std::vector<CorrectedPose> keyframes;
};

struct OccupancySlice {
  static constexpr MessageType kType = MessageType::kOccupancySlice;
  static constexpr int8_t kUnknown = -1, kFree = 0, kOccupied = 100;
  Header header;
  std::string robot_id;
  SE3 T_map_grid = SE3::Identity();
  float resolution_m = 0.05f;
  int width = 0, height = 0;
  float z_min_m = 0.0f, z_max_m = 2.0f;
  std::vector<int8_t> cells;  ///< width * height, row-major; -1 unknown, 0..100 occupancy
};

/// One accepted loop edge between two optimised keyframes (positions in the map frame).
struct MapLoopEdge {
  std::string robot_from;
  int keyframe_from = 0;
  std::string robot_to;
  int keyframe_to = 0;
  bool inter_robot = false;  ///< the keyframes are of different odometry chains
  Vec3 p_from = Vec3::Zero(), p_to = Vec3::Zero();
};

/// Server -> robot after an optimisation: the loop edges of the robot's map (for visualisers).
struct LoopEdges {
  static constexpr MessageType kType = MessageType::kLoopEdges;
  Header header;
  std::string robot_id;
  int64_t graph_revision = 0;
  std::vector<MapLoopEdge> edges;
};

enum class MapCompression : int8_t { kNone = 0, kZstd = 1 };

struct MapUpdate {
  static constexpr MessageType kType = MessageType::kMapUpdate;
  Header header;
  int64_t map_revision = 0;
  double resolution_m = 0.05;
  bool full = true;
  MapCompression compression = MapCompression::kNone;
  int raw_size = 0;  ///< octree bytes after decompression
  Bytes data;        ///< see map_payload.hpp to fill and read it
  /// The newest keyframe of the channel's robot that this tree holds (-1: none): how fresh the map is
  /// (rgbdmap-viewer passes it on; deploy/bench_viewer.sh measures acknowledgement -> voxels with it).
  int robot_keyframe_id = -1;
};

struct VelocityCommand {
  static constexpr MessageType kType = MessageType::kVelocityCommand;
  Header header;
  std::string robot_id;
  Vec3 linear_mps = Vec3::Zero();
  Vec3 angular_radps = Vec3::Zero();
  double duration_s = 0.0;
};

struct RobotStatus {
  std::string robot_id;
  int keyframes = 0;
  int loop_closures = 0;
  int64_t rejected_messages = 0;
  int64_t last_utime = 0;
  bool localize = false;  ///< map mode "localize": placed in the stored map, its keyframes never stored
  bool placed = true;     ///< in the map; false while a localising robot is not placed yet ("unplaced")
};

/// Messages the server rejected from one claimed sender for one reason (since the server started).
struct RejectCount {
  std::string robot_id;  ///< a robot the server knows; "" for every other claimed sender ("unknown")
  std::string reason;    ///< [A-Za-z0-9_-]{1,32}, e.g. "bad_signature", "replayed_seq", "unknown_robot"
  int64_t count = 0;
};

struct ServerStatus {
  static constexpr MessageType kType = MessageType::kServerStatus;
  Header header;
  std::string state = "running";
  double uptime_s = 0.0;
  int64_t graph_revision = 0;
  int64_t map_revision = 0;
  std::vector<RobotStatus> robots;
  std::vector<RejectCount> rejects;  ///< at most kMaxRejectCounts, largest counts first
};

}  // namespace rgbdmap::msg
