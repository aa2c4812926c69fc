// Corrections that follow the robots' heartbeats. PoseCorrections go out after an optimisation, once and
// best effort; a robot waits for the one covering its last keyframe before it ends. Two cases would leave it
// waiting its whole final wait: that message was lost, or no optimisation came after its last keyframe
// (no loop was added). Every heartbeat names the robot's last keyframe, so on each tick:
//   - covered by the newest corrections sent to it: send them again, at most kMaxSends times in all and
//     kResendAfter apart, only while the robot is heard after the last send (it may still be waiting);
//   - in the graph but not covered: once the robot has named it for kSettle (it stopped sending), one
//     optimisation for it, whose corrections (a new revision) cover it.
// The robot ignores a revision it has, so a copy that was not lost costs only its bytes.
#include <algorithm>

#include "ingest_pipeline.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {
namespace {

using Clock = std::chrono::steady_clock;
constexpr int kMaxSends = 8;
constexpr auto kResendAfter = std::chrono::milliseconds(900);
constexpr auto kSettle = std::chrono::milliseconds(900);

bool covers(const msg::PoseCorrections& c, int keyframe_id) {
  return std::any_of(c.keyframes.begin(), c.keyframes.end(),
                     [&](const msg::CorrectedPose& p) { return p.keyframe_id == keyframe_id; });
}

}  // namespace

void IngestPipeline::onTick() {
  Lock lock(mutex_);
  const auto now = Clock::now();
  giveUpWaitingLocked(now, config_.reorder_timeout_s, true);
  const Published again = followHeartbeatsLocked(now);
  lock.unlock();
  for (const auto& [robot, c] : again) {
    log::debug("server: corrections (revision ", c.graph_revision, ") to ", robot, " again");
    publisher_.publish(robot, c);
  }
}

void IngestPipeline::noteCorrectionsLocked(const std::map<std::string, msg::PoseCorrections>& corrections,
                                           Clock::time_point now) {
  for (const auto& [robot, c] : corrections) {
    CorrectionsSent& sent = corrections_sent_[robot];
    sent.last = c;
    sent.robot_session = registry_.currentSession(robot);
    sent.sends = 1;
    sent.sent_at = now;
  }
}

IngestPipeline::Published IngestPipeline::followHeartbeatsLocked(Clock::time_point now) {
  Published out;
  bool optimise = false;
  for (const auto& [robot_id, hb] : registry_.heartbeats()) {
    const int robot = registry_.index(robot_id);
    if (robot < 0 || hb.last_keyframe_id < 0 || hb.session != registry_.currentSession(robot_id)) continue;
    const KeyframeKey key{robot, hb.session, hb.segment, hb.last_keyframe_id};
    if (!index_.contains(key)) continue;  // not in the graph (yet)
    CorrectionsSent& sent = corrections_sent_[robot_id];
    if (sent.sends > 0 && sent.robot_session == hb.session && covers(sent.last, hb.last_keyframe_id)) {
      if (sent.sends < kMaxSends && hb.heard > sent.sent_at && now - sent.sent_at >= kResendAfter) {
        ++sent.sends;
        sent.sent_at = now;
        ++counters_.corrections_resent;
        out.emplace_back(robot_id, sent.last);
      }
    } else if (now - hb.naming_since >= kSettle && sent.optimised_for != key) {
      sent.optimised_for = key;
      optimise = true;
    }
  }
  if (optimise) {
    ++counters_.optimizations_for_heartbeats;
    submitOptimizationLocked();
  }
  return out;
}

}  // namespace rgbdmap
