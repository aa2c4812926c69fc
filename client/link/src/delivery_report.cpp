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

/// The server's counters for this robot other than bad signatures, e.g. "3 replayed_seq, 1 malformed".
std::string otherServerRejects(const RobotLinkStats& l) {
  std::string out;
  for (const auto& [reason, count] : l.server_rejects)
    if (reason != "bad_signature" && !isNotServedReason(reason) && count > 0)
      out += (out.empty() ? "" : ", ") + std::to_string(count) + " " + reason;
  return out;
}

int64_t serverBadSignatures(const RobotLinkStats& l) {
  const auto it = l.server_rejects.find("bad_signature");
  return it == l.server_rejects.end() ? 0 : it->second;
}

std::string noServerHeard(const RobotLinkStats& l) {
  std::string out = "no server heard at all (no valid message for this robot arrived)";
  if (l.bad_signatures > 0)
    return out + "; " + std::to_string(l.bad_signatures) +
           " messages with a bad signature arrived: the server holds another key for this robot";
  return out +
         ". Check that rgbdmap-server runs on the same transport (URL; CYCLONEDDS_URI for DDS; the multicast "
         "route for LCM), serves this robot id and holds this robot's key (it ignores messages it cannot "
         "verify, without answering)";
}

/// Why a server that was heard did not accept them all.
std::string heardWhy(const RobotLinkStats& l) {
  if (l.keyframes_refused > 0) return "refused: " + refusals(l);
  if (l.keyframes_pending > 0 || l.keyframes_given_up > 0) return "server heard but no ack (loss?)";
  return "";
}

}  // namespace

bool isNotServedReason(const std::string& reason) {
  return reason == "unknown_robot" || reason == "unknown_sender";
}

std::string notServedReason(const RobotLinkStats& l) {
  if (l.server_rejects.count("unknown_robot") != 0) return "it is not in the server's robot list";
  if (l.server_rejects.count("unknown_sender") != 0) return "the server holds no key for it";
  return "";
}

DeliveryReport deliveryReport(const RobotRunResult& r, const std::string& robot_id) {
  const RobotLinkStats& l = r.link;
  DeliveryReport d;
  d.keyframes = r.keyframes;
  d.unaccepted = std::max(0, r.keyframes - static_cast<int>(l.keyframes_acked - l.recovered_acked));
  d.spooled = static_cast<int>(l.spool_depth);
  const int recovered_pending =
      static_cast<int>(l.spool_recovered) - static_cast<int>(l.recovered_acked + l.recovered_refused);
  const int spooled_now = std::max(0, d.spooled - std::max(0, recovered_pending));
  d.lost = std::max(0, d.unaccepted - spooled_now) + static_cast<int>(l.recovered_refused);
  d.server_heard = l.server_heard;
  if (d.unaccepted == 0 && d.lost == 0) return d;
  const std::string who = robot_id.empty() ? "this robot" : robot_id;
  const std::string count =
      std::to_string(d.unaccepted) + " of " + std::to_string(d.keyframes) + " keyframes not accepted";
  if (const std::string why = notServedReason(l); !d.server_heard && !why.empty()) {
    d.message = count + ": the server does not serve robot id '" + who + "': " + why +
                " (its unsigned notice, not verifiable here). Add it to server.robots and its key to "
                "server.keys_file";
  } else if (const int64_t bad = serverBadSignatures(l); bad > 0) {
    d.message = count + ": the server refused " + std::to_string(bad) + " messages from " + who +
                " (hellos, heartbeats, keyframe chunks) for a bad signature (wrong key?)";
    if (!l.server_rejects_verified)
      d.message += "; read from a server status this robot could not verify (" +
                   std::to_string(l.bad_signatures) + " bad signatures here): the keys differ";
  } else if (!d.server_heard) {
    d.message = count + ": " + noServerHeard(l);
  } else {
    d.message = count + " by the server (it was heard): " + breakdown(r);
    if (const std::string why = heardWhy(l); !why.empty()) d.message += "; " + why;
  }
  if (const std::string other = otherServerRejects(l); !other.empty())
    d.message += "; the server reports rejected messages from " + who + ": " + other;
  if (d.spooled > 0)
    d.message += "; " + std::to_string(d.spooled) + " keyframes are in the spool: the next start sends them";
  return d;
}

}  // namespace rgbdmap
