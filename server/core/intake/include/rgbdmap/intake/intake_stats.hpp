#pragma once
// The counters of the server's receive side, each struct owned and filled by the part that counts: per robot
// by RobotRegistry (ServerRobotStats; the ingest side adds what it places), the inbox's by Inbox
// (InboxStats), the Hello hold's by HelloHold (HelloHoldStats). MapServerStats holds them; stats_json.cpp
// serialises them once.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct ServerRobotStats {
  std::string robot_id;
  int keyframes = 0;
  int sessions = 0;     ///< robot processes seen (a restart is a new session)
  int chains = 0;       ///< odometry chains (segments over all sessions)
  int loops = 0;        ///< accepted loop edges touching this robot's keyframes
  int map_id = -1;      ///< graph component of its newest keyframe (first node id of the component)
  bool merged = false;  ///< its newest keyframe shares a component with another robot
  uint64_t bytes_received = 0;
  uint64_t bytes_sent = 0;
  uint64_t keyframes_refused = 0;  ///< acknowledged with accepted = false
  uint64_t duplicates = 0;         ///< re-sent keyframes acknowledged again
  uint64_t out_of_order = 0;       ///< stored before their predecessor was in the graph (they waited)
  uint64_t chain_splits = 0;       ///< keyframes that started a new chain: their predecessor never came
                                   ///< (reorder bound or timeout) or was refused
  uint64_t waiting_for_hello = 0;  ///< keyframes that came before the robot's Hello (held, taken in with it)
  int keyframes_waiting = 0;       ///< stored, acknowledged, waiting for their predecessor now
  /// Fair share: keyframes left unacknowledged because its queue was full, or because it sent
  /// over server.robot_max_keyframes_per_s; refused from the images' headers, before decoding.
  uint64_t queue_full = 0;
  /// Re-sent while the first copy was still in its queue: not queued twice, no slot taken, not demoted.
  uint64_t duplicates_queued = 0;
  uint64_t throttled = 0;
  uint64_t refused_before_decode = 0;
  int keyframes_queued = 0;      ///< in its ingest queue now
  int keyframes_queued_max = 0;  ///< the most it has had queued at once (at most robot_queue_capacity)
  int64_t last_utime = 0;
  std::optional<CameraIntrinsics> camera;
  /// Map mode of its newest Hello: "map" (its keyframes are stored and build the map) or "localize" (placed
  /// in the stored map, never stored).
  std::string mode = "map";
  /// Placed in the map: a mapping robot's newest keyframe is in the map of the graph's first keyframe; a
  /// localising robot's session was placed by the placement rules. False: "unplaced".
  bool placed = false;
  double first_placement_s = -1.0;  ///< localising: its session's first keyframe -> first placement; -1: none
  uint64_t keyframes_localized = 0;  ///< localising keyframes taken (acknowledged, never stored)
  uint64_t keyframes_matched = 0;    ///< of them, placed by verified matches of their own
};

/// What the inbox counted on the receive thread.
struct InboxStats {
  uint64_t messages_rejected = 0;             ///< RejectCounters total (auth, replay, malformed, ...)
  uint64_t unknown_robot_messages = 0;        ///< authentic, from a robot not in the server's robot list
  uint64_t keyframes_dropped_queue_full = 0;  ///< all robots' queue_full
  uint64_t keyframes_duplicates_queued = 0;   ///< all robots' duplicates_queued
  uint64_t keyframes_throttled = 0;           ///< all robots' throttled
  uint64_t refusal_notices_sent = 0;          ///< unsigned "not serving R" notices (RefusalNotices)
  uint64_t keyframe_acks_repeated = 0;  ///< KeyframeAcks sent again for a duplicate chunk (KeyframeAnswers)
  /// Rejected messages per claimed robot and reason, largest first (robot_id "" = every claimed sender
  /// that is not a known robot); what ServerStatus::rejects carries.
  std::vector<msg::RejectCount> rejects;
};

/// Keyframes that came before their robot's Hello, held (not stored or acknowledged yet) until it comes,
/// and those the hold's bounds pushed out (the robot sends them again).
struct HelloHoldStats {
  int keyframes_held = 0;
  uint64_t keyframes_dropped = 0;
};

}  // namespace rgbdmap
