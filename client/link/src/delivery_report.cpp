#include "rgbdmap/link/delivery_report.hpp"

#include <algorithm>

namespace rgbdmap {
namespace {

std::string refusals(const RobotLinkStats& l) {
  std::string out;
  for (const auto& [reason, count] : l.refused_by_reason)
    out += (out.empty() ? "" : "; ") + std::to_string(count) + " x \"" + reason + "\"";
  return out;
}

/// What became of the keyframes the server did not accept, e.g. "refused 2 (...), given up 1".
std::string breakdown(const RobotRunResult& r) {
  const RobotLinkStats& l = r.link;
  std::string out;
  auto add = [&out](uint64_t n, const std::string& what) {
    if (n > 0) out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + what;
  };
  add(l.keyframes_refused, "refused (" + refusals(l) + ")");
  add(l.keyframes_given_up, "given up after link.reliable.max_attempts transmissions");
  add(l.keyframes_pending, "still unanswered after link.final_wait_s");
  add(static_cast<uint64_t>(std::max(0, r.keyframes_not_sent)), "not sent (send window full, or stopped)");
  return out;
}

}  // namespace

DeliveryReport deliveryReport(const RobotRunResult& r) {
  DeliveryReport d;
  d.keyframes = r.keyframes;
  d.unaccepted = std::max(0, r.keyframes - static_cast<int>(r.link.keyframes_acked));
  d.server_heard = r.link.server_heard;
  if (d.unaccepted == 0) return d;
  const std::string count =
      std::to_string(d.unaccepted) + " of " + std::to_string(d.keyframes) + " keyframes not accepted";
  if (!d.server_heard) {
    d.message = count + ": no server heard at all (no valid message for this robot arrived)";
    if (r.link.bad_signatures > 0)
      d.message += "; " + std::to_string(r.link.bad_signatures) +
                   " messages with a bad signature arrived: the server holds another key for this robot";
    else
      d.message +=
          ". Check that rgbdmap-server runs on the same transport (URL; CYCLONEDDS_URI for DDS; the "
          "multicast route for LCM), serves this robot id and holds this robot's key (it ignores messages "
          "it cannot verify, without answering)";
  } else {
    d.message = count + " by the server (it was heard): " + breakdown(r);
  }
  return d;
}

}  // namespace rgbdmap
