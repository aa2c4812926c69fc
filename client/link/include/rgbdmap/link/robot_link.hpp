#pragma once
// The robot's side of the mapping protocol (proto/README.md) over any transport::Transport:
//  - says Hello at start (again every hello_period_s, or 0.2 s once the server was heard, until the server
//    shows it registered the robot) and sends a Heartbeat every heartbeat_period_s with the tracking state
//    the odometry last reported;
//  - sends each keyframe (images encoded once, message kept unsealed) through a ReliableSender keyed by the
//    keyframe id; every (re)transmission is sealed afresh with a new seq; KeyframeAck removes it (accepted)
//    or refuses it for good (accepted = false: counted, not resent);
//  - applies PoseCorrections: per odometry segment s, T_map_odom(s) = T_map_cam(k) * T_odom_cam(k)^-1 for
//    the newest corrected keyframe k of s (the robot knows T_odom_cam of its own keyframes); corrections
//    whose graph_revision is not newer than the last one of the same server session are ignored;
//  - keeps the latest OccupancySlice, VelocityCommand and ServerStatus.
// Every received message goes through msg::openEnvelope + msg::decodeMessage with a ReplayGuard and
// RejectCounters; it must come from sender "server" and name this robot, or it is counted and ignored.
//
// Threads: the transport's receive thread runs the handlers (short: decode, update state under a mutex,
// acknowledge; they never wait); one worker sends Hello/Heartbeat; the ReliableSender's worker retransmits.
// The transport may be shared by several links and a server; it must outlive the link. Handlers the link
// registered stay registered (Transport has no unsubscribe) but do nothing once the link is stopped or gone.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/codec/image_codec.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/link/keyframe_spool.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/transport/reliable.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {

struct RobotLinkOptions {
  std::string robot_id;
  msg::Bytes key;           ///< empty: unsigned messages (server in open mode); else >= 16 bytes
  CameraIntrinsics camera;  ///< sent in Hello
  /// The camera's optical frame in the robot's base frame (REP-103), sent in Hello: the server anchors the
  /// robot's first keyframe at T_map_cam = T_base_camera * T_odom_cam, so the map frame is z-up.
  SE3 T_base_camera = defaultT_base_camera();
  /// Map mode "localize" (announced in Hello): the server places and tracks the robot in its stored map and
  /// never stores its keyframes (they are acknowledged all the same). false: "map", they build the map.
  bool localize = false;
  ImageCodecOptions codec;  ///< keyframe images (rgbdmap/codec/image_codec.hpp)
  /// Keyframes carry the odometry's keypoints and descriptors (51 KB per keyframe on TUM fr1). Off (the
  /// default), the server extracts them from the decoded colour with its own `features:` configuration,
  /// which must match the odometry's `orb:` section; codec.color must not be none. On fr1_rpy both give
  /// the same full-system ATE (0.0148-0.0151 m) and off halves the keyframe (58 KB instead of 115 KB).
  bool send_features = false;
  transport::ReliableSenderOptions reliable;
  double heartbeat_period_s = 1.0, hello_period_s = 1.0;
  double send_timeout_s = 30.0;  ///< sendKeyframe waits at most this for room in the send window
  /// Keyframes in chunks of this many bytes, acknowledged and resent one by one (KeyframeChunk, ChunkAck):
  /// for udpm://, where a lost IP fragment loses a whole LCM message. 0 = whole keyframes; -1 = choose by
  /// the transport URL (resolveChunkBytes: 1100 for udpm://, else 0).
  int chunk_bytes = -1;
  std::string software_version = "rgbdmap-client 0.1.0";  ///< sent in Hello
  /// RobotPose (the live pose, for visualisers) at most every this many seconds; 0 = never.
  double pose_period_s = 0.2;
  /// Set: called with each keyframe's encoded (unsealed) msg::Keyframe payload once it is in the send
  /// window, on the sending thread (rgbdmap-client --record-keyframes: KeyframeStreamWriter::append).
  std::function<void(const msg::Bytes& payload)> keyframe_tap;
  /// Set: every keyframe is written to this spool before it is offered to the server and leaves it when
  /// answered. sendKeyframe returns once it is spooled: the send window draws from the spool, so an outage
  /// of any length blocks nothing and keeps only the window in memory. The keyframes an earlier process
  /// left are sent first, and the link signs with the spool's session. A keyframe the spool cannot take
  /// (budget, full disk) is sent live only, as without a spool. Null: keyframes live in memory only.
  std::shared_ptr<KeyframeSpool> spool;

  /// Empty when valid, else every reason ("; "-separated).
  std::string validate() const;
};

/// The Hello a link with these options sends (also the first record of a recorded keyframe stream).
msg::Hello makeHello(const RobotLinkOptions& options);

/// `configured` if >= 0, else the default for the transport URL: 1100 for udpm:// (one chunk per Ethernet
/// datagram), 0 otherwise (DDS retransmits lost fragments itself; memq:// loses nothing).
int resolveChunkBytes(int configured, const std::string& transport_url);

struct RobotLinkStats {
  uint64_t keyframes_sent = 0;      ///< submitted (first transmission)
  uint64_t keyframes_acked = 0;     ///< accepted by the server (each id once)
  uint64_t keyframes_refused = 0;   ///< accepted = false (each id once); not resent
  uint64_t keyframes_given_up = 0;  ///< max_attempts reached without an answer
  uint64_t keyframes_pending = 0;   ///< still waiting for an answer
  uint64_t retransmissions = 0;
  /// The ReliableSender's ack latency estimate (RFC 6298, from acks of keyframes sent once) and the
  /// retransmission timeout it gives a new keyframe now; 0 before any sample (rto: initial_backoff).
  uint64_t rtt_samples = 0;
  double srtt_ms = 0.0, rttvar_ms = 0.0, rto_ms = 0.0;
  uint64_t chunks_sent = 0, chunks_resent = 0, chunk_acks = 0;  ///< chunked keyframes (chunk_bytes > 0)
  uint64_t duplicate_acks = 0;        ///< acks for an id already answered (the server re-acks duplicates)
  uint64_t unknown_acks = 0;          ///< acks for an id this process never sent
  uint64_t corrections_received = 0;  ///< PoseCorrections applied
  uint64_t corrections_stale = 0;     ///< ignored: graph_revision not newer
  uint64_t slices_received = 0, commands_received = 0, status_received = 0;
  uint64_t poses_sent = 0;     ///< RobotPose messages (publishPose, throttled to pose_period_s)
  uint64_t commands_sent = 0;  ///< publishCommand (the robot's own avoidance commands on its cmd_vel channel)
  uint64_t hellos_sent = 0, heartbeats_sent = 0;
  uint64_t link_status_sent = 0;  ///< LinkStatus (spool, window, diagnosis) for the monitor, once a heartbeat
  uint64_t messages_rejected = 0;  ///< every rejection (envelope, payload, wrong sender or robot)
  uint64_t bytes_sent = 0, bytes_received = 0;  ///< this link's messages only (the transport may be shared)
  /// The parts of the keyframes passed to sendKeyframe, summed once per keyframe (retransmissions are in
  /// bytes_sent only): the depth and colour blobs, and the features as the LCM schema carries them
  /// (21 bytes per keypoint + 32 per descriptor; none with send_features false). The rest of bytes_sent
  /// is envelopes, the other fields, retransmissions, heartbeats, hellos and poses.
  uint64_t keyframe_depth_bytes = 0, keyframe_color_bytes = 0, keyframe_feature_bytes = 0;
  /// The whole keyframe message (its LCM encoding, all parts and fields), summed once per keyframe; the
  /// signed envelope adds ~90 bytes (header and MAC) per transmission.
  uint64_t keyframe_message_bytes = 0;
  int64_t graph_revision = -1;  ///< of the last applied PoseCorrections; -1 before any
  bool server_heard = false;    ///< a valid message from the server for this robot has arrived
  uint64_t bad_signatures = 0;  ///< of messages_rejected: signature did not verify (another key?)
  std::map<std::string, uint64_t> refused_by_reason;  ///< KeyframeAck reason -> refused keyframes
  /// This robot's entries in the latest ServerStatus::rejects (reason -> messages the server rejected that
  /// claimed to be from this robot, e.g. "bad_signature"). A robot whose key differs from the server's
  /// cannot verify the status: it is then read unverified, as a hint for the delivery report only
  /// (server_rejects_verified false); a verified status always replaces an unverified one.
  std::map<std::string, int64_t> server_rejects;
  bool server_rejects_verified = false;
  bool server_status_seen = false;  ///< any ServerStatus arrived, verified or not
  /// Unsigned "not serving <robot>" notices of a server that holds no key for this robot or does not list
  /// it (not rejections; server_rejects then holds "unknown_sender" or "unknown_robot").
  uint64_t not_served_notices = 0;
  /// The link's likely state in a few words, for a status line: "" for the first 3 s, then "server heard",
  /// "no server heard", "keys differ" or "not served by the server" (RobotLink's diagnosis; also logged).
  std::string diagnosis;
  /// Time from a keyframe's first transmission to its (first) accepting ack, over the accepted keyframes
  /// (bounded reservoir, common/sample_reservoir.hpp); 0 before any.
  uint64_t ack_latency_samples = 0;
  double ack_latency_ms_median = 0.0, ack_latency_ms_p90 = 0.0, ack_latency_ms_max = 0.0;
  /// With a keyframe spool (all 0 without): keyframes in it and not answered (spool_depth, their records'
  /// bytes, the wall clock in us when the oldest was spooled, 0 for none), left by an earlier process at
  /// start (spool_recovered; answered since: recovered_acked, recovered_refused, also counted in
  /// keyframes_acked / keyframes_refused), waiting for room in the send window (keyframes_queued), written
  /// by this process (keyframes_spooled) or sent live only because the spool could not take them
  /// (keyframes_live_only: budget or disk full), records found damaged at start (spool_damaged).
  uint64_t spool_depth = 0, spool_bytes = 0, spool_recovered = 0, spool_damaged = 0;
  int64_t spool_oldest_utime = 0;
  uint64_t recovered_acked = 0, recovered_refused = 0;
  uint64_t keyframes_queued = 0, keyframes_spooled = 0, keyframes_live_only = 0;
  /// Spooled keyframes the sender gave up after link.reliable.max_attempts sends and that went back to the
  /// queue (not in keyframes_given_up, which counts the live-only ones lost that way).
  uint64_t keyframes_requeued = 0;
  /// Of keyframes_pending: sent live only (not in a spool), lost if the process ends now.
  uint64_t keyframes_pending_live = 0;
  /// DDS: keyframe sends held because no subscriber was matched (they reach nobody), and new subscribers
  /// (a restarted server) that matched while keyframes were in flight, each sending them again at once.
  uint64_t sends_held_unmatched = 0, subscriber_matches = 0;
};

class RobotLink {  // thread-safe; handlers never block the transport's receive thread
 public:
  RobotLink(transport::Transport& transport, RobotLinkOptions options);
  ~RobotLink();  ///< stop()s
  RobotLink(const RobotLink&) = delete;
  RobotLink& operator=(const RobotLink&) = delete;

  /// Checks the options, subscribes the server->robot channels, starts the transport (idempotent), the
  /// sender and heartbeat threads, and says Hello. Fails on invalid options or a second start.
  Status start();
  /// Stops the threads at once and wakes every waiter (they return false); idempotent. Received messages
  /// are ignored from then on; the state (corrections, stats) stays readable.
  void stop();

  /// Encodes the images, builds the message (keyframeToMessage), submits it reliably; blocks while the send
  /// window is full (up to send_timeout_s, less if stop() is called). Remembers T_odom_cam and segment.
  Status sendKeyframe(const Keyframe& keyframe, const RgbdFrame& frame);
  /// Sends a keyframe message as it is (a recorded one: rgbdmap-replay), under this link's robot id. Its
  /// id, segment, odometry edge and images are the caller's; the same checks and window as sendKeyframe.
  Status sendKeyframeMessage(msg::Keyframe message);
  /// Publishes a VelocityCommand (robot_id set to this robot) on the robot's cmd_vel channel, signed like
  /// every message of this robot, for the robot's motor controller. The link does not take its own commands
  /// back as server commands (latestCommand stays the server's): their echo is recognised and dropped.
  Status publishCommand(const msg::VelocityCommand& command);
  /// The live pose of a tracked frame, T_map_cam = mapFromOdom(segment) * T_odom_cam, as a best-effort
  /// RobotPose on the robot's pose channel (for visualisers); at most one every pose_period_s, the others
  /// are skipped (success). Off when pose_period_s is 0.
  Status publishPose(double timestamp, int segment, int reference_keyframe, TrackingState state,
                     const SE3& T_odom_cam);
  /// What the next heartbeats report.
  void setTrackingState(int last_keyframe_id, int segment, TrackingState state);

  /// T_map_odom; until a correction covers the segment, T_base_camera (where the server places a new chain).
  SE3 mapFromOdom(int segment) const;
  std::optional<SE3> correctedKeyframe(int keyframe_id) const;  ///< latest T_map_cam from the server
  std::optional<msg::OccupancySlice> latestSlice() const;
  std::optional<msg::VelocityCommand> latestCommand() const;
  std::optional<msg::ServerStatus> latestServerStatus() const;
  /// True once every keyframe sent has been answered (accepted or refused); false on timeout, on stop(),
  /// or when one was given up. A give-up is noticed within one heartbeat period.
  bool waitAllAcked(double timeout_s);
  /// True once a PoseCorrections covering keyframe `keyframe_id` has arrived; false on timeout or stop().
  bool waitForCorrection(int keyframe_id, double timeout_s);
  /// True once PoseCorrections of graph revision >= `revision` (MapServerStats::graph_revision) have been
  /// applied; false on timeout or stop().
  bool waitForGraphRevision(int64_t revision, double timeout_s);
  RobotLinkStats stats() const;
  /// Keyframe id -> wall-clock time (us since the epoch) its accepting ack arrived, for the accepted ones.
  std::map<int, int64_t> keyframeAckTimes() const;

 private:
  class Impl;
  std::shared_ptr<Impl> impl_;  ///< handlers hold a weak_ptr, so a handler never outlives what it uses
};

}  // namespace rgbdmap
