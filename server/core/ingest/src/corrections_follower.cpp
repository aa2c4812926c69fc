#include "rgbdmap/ingest/corrections_follower.hpp"

#include <algorithm>

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

CorrectionsFollower::CorrectionsFollower(const RobotRegistry& registry, IngestStats& stats)
    : registry_(registry), stats_(stats) {}

void CorrectionsFollower::noteSent(const std::map<std::string, msg::PoseCorrections>& corrections,
                                   Clock::time_point now) {
  for (const auto& [robot, c] : corrections) {
    CorrectionsSent& sent = corrections_sent_[robot];
    sent.last = c;
    sent.robot_session = registry_.currentSession(robot);
    sent.sends = 1;
    sent.sent_at = now;
  }
}

CorrectionsFollower::FollowUp CorrectionsFollower::followHeartbeats(Clock::time_point now,
                                                                    const KeyframeIndex& index) {
  FollowUp out;
  for (const auto& [robot_id, hb] : registry_.heartbeats()) {
    const int robot = registry_.index(robot_id);
    if (robot < 0 || hb.last_keyframe_id < 0 || hb.session != registry_.currentSession(robot_id)) continue;
    const KeyframeKey key{robot, hb.session, hb.segment, hb.last_keyframe_id};
    if (!index.contains(key)) continue;  // not in the graph (yet)
    CorrectionsSent& sent = corrections_sent_[robot_id];
    if (sent.sends > 0 && sent.robot_session == hb.session && covers(sent.last, hb.last_keyframe_id)) {
      if (sent.sends < kMaxSends && hb.heard > sent.sent_at && now - sent.sent_at >= kResendAfter) {
        ++sent.sends;
        sent.sent_at = now;
        ++stats_.corrections_resent;
        out.again.emplace_back(robot_id, sent.last);
      }
    } else if (now - hb.naming_since >= kSettle && sent.optimised_for != key) {
      sent.optimised_for = key;
      out.optimise = true;
    }
  }
  if (out.optimise) ++stats_.optimizations_for_heartbeats;
  return out;
}

}  // namespace rgbdmap
