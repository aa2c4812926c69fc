// RobotLink on a transport that matches endpoints (DDS). A keyframe published while its channel has no
// matched subscriber reaches nobody, and one published before a subscriber (a starting or restarted
// server) matched never reaches that subscriber: DDS repairs losses only between matched endpoints. So no
// keyframe is published while nothing is matched (the ReliableSender's schedule tries again), and when a new
// subscriber matches, every keyframe in flight is sent again at once rather than after its timeout. On
// LCM and memq nothing changes.
#include "rgbdmap/common/logging.hpp"
#include "robot_link_impl.hpp"

namespace rgbdmap {

bool RobotLink::Impl::deliveryMatched() {
  const std::optional<transport::SubscriberMatch> match = transport_.matchedSubscribers(deliveryChannel());
  if (!match || match->current > 0) return true;
  std::lock_guard<std::mutex> lock(mutex_);
  ++counts_.sends_held_unmatched;
  return false;
}

bool RobotLink::Impl::watchMatches() {
  const std::optional<transport::SubscriberMatch> match = transport_.matchedSubscribers(deliveryChannel());
  if (!match) return false;
  const uint64_t before = matched_total_.exchange(match->total);
  if (match->total > before && match->current > 0 && reliable_.pending() > 0) {
    log::debug("robot ", options_.robot_id, ": a new subscriber of ", deliveryChannel(),
               " matched: ", reliable_.pending(), " keyframes in flight sent again now");
    reliable_.resendAllNow();
    std::lock_guard<std::mutex> lock(mutex_);
    ++counts_.subscriber_matches;
  }
  return true;
}

}  // namespace rgbdmap
