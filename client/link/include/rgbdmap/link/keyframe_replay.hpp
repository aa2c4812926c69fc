#pragma once
// Sends a recorded keyframe stream (keyframe_stream.hpp) again through a RobotLink as a light robot: no
// camera, no odometry, only the link's work (sign, send, resend, acks, heartbeats). For scale tests many of
// these run against one server (rgbdmap-replay, deploy/bench_fleet.sh).
//
// Passes: the first pass sends the stream from keyframe `start` to its end, every further pass the whole
// stream, until `duration_s` is over (0: one pass). Pass p sends keyframe id k as p * (max id + 1) + k in
// segment p * (max segment + 1) + s, with timestamps shifted past the previous pass, and its first keyframe
// (like any whose predecessor this pass did not send) starts a new chain: to the server it is a robot that
// lost tracking and came back, to be joined by loop closure.
#include <cstddef>
#include <vector>

#include "rgbdmap/link/keyframe_stream.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/link/robot_runner.hpp"

namespace rgbdmap {

struct ReplayOptions {
  double rate_hz = 0.0;  ///< keyframes per second; 0 = the recording's own timestamps
  /// Further passes while keyframes fall due before this (due times from the rate or the timestamps, not
  /// from the clock: the count does not depend on the load); 0 = one pass.
  double duration_s = 0.0;
  size_t start = 0;  ///< the first pass begins at this keyframe of the stream (taken modulo its size)
  double final_wait_s = 20.0;  ///< at the end, wait at most this for every acknowledgement
  const StopRequest* stop = nullptr;
  /// Added to every id and segment sent (a link with a keyframe spool: KeyframeSpool::firstKeyframeId and
  /// firstSegment, above what its session used).
  int first_keyframe_id = 0, first_segment = 0;
};

struct ReplayedKeyframe {
  int id = 0;            ///< as sent (after the pass's offset)
  double sent_s = 0.0;   ///< since the replay began
  double ack_ms = -1.0;  ///< submission to the accepting ack; -1 = not accepted
};

struct ReplayResult {
  std::vector<ReplayedKeyframe> keyframes;  ///< every keyframe submitted, in order
  size_t send_failures = 0;                 ///< sendKeyframeMessage refused (window full, link stopped)
  size_t passes = 0;
  double wall_s = 0.0;
  bool stopped = false;  ///< a stop request ended it early
  RobotLinkStats link;   ///< the link's counters at the end
  size_t acked() const;
  /// q-quantile of the acked keyframes' latencies whose send time is in [from_s, to_s); 0 when none.
  double ackQuantileMs(double q, double from_s = 0.0, double to_s = 1e300) const;
};

/// Replays `stream` through `link` (started; its options carry the stream's camera). Blocks until done.
ReplayResult replayKeyframes(const KeyframeStream& stream, RobotLink& link, const ReplayOptions& options);

}  // namespace rgbdmap
