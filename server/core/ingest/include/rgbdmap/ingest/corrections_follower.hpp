#pragma once
// Corrections that follow the robots' heartbeats. PoseCorrections go out after an optimisation, once and
// best effort; a robot waits for the one covering its last keyframe before it ends. Two cases would leave it
// waiting its whole final wait: that message was lost, or no optimisation came after its last keyframe
// (no loop was added). Every heartbeat names the robot's last keyframe, so on each tick:
//   - covered by the newest corrections sent to it: send them again, at most kMaxSends times in all and
//     kResendAfter apart, only while the robot is heard after the last send (it may still be waiting);
//   - in the graph but not covered: once the robot has named it for kSettle (it stopped sending), one
//     optimisation for it, whose corrections (a new revision) cover it.
// The robot ignores a revision it has, so a copy that was not lost costs only its bytes. Not thread-safe:
// IngestPipeline calls it under its state lock.
#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/ingest/keyframe_index.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

class CorrectionsFollower {
 public:
  using Published = std::vector<std::pair<std::string, msg::PoseCorrections>>;
  struct FollowUp {
    Published again;        ///< corrections to send again
    bool optimise = false;  ///< an optimisation for a heartbeat keyframe no corrections cover
  };

  /// References must outlive the follower.
  CorrectionsFollower(const RobotRegistry& registry, IngestStats& stats);

  /// Remembers what an optimisation told each robot (the first send of it).
  void noteSent(const std::map<std::string, msg::PoseCorrections>& corrections,
                std::chrono::steady_clock::time_point now);
  /// For each robot whose heartbeat names a keyframe in the graph (`index`): the newest corrections again
  /// when they cover it and may have been lost, or an optimisation when none covers it yet.
  FollowUp followHeartbeats(std::chrono::steady_clock::time_point now, const KeyframeIndex& index);

 private:
  struct CorrectionsSent {
    msg::PoseCorrections last;  ///< the newest sent to the robot
    int64_t robot_session = 0;  ///< the robot's process they were built for
    int sends = 0;              ///< how often `last` went out
    std::chrono::steady_clock::time_point sent_at;
    std::optional<KeyframeKey> optimised_for;  ///< the heartbeat keyframe an optimisation was asked for
  };

  const RobotRegistry& registry_;
  IngestStats& stats_;
  std::map<std::string, CorrectionsSent> corrections_sent_;
};

}  // namespace rgbdmap
