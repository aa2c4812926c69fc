// RobotLink: the handlers of the server->robot channels, and what the robot makes of them when none is
// valid (diagnoseLink). The handlers run on the transport's receive thread, so they only decode, update state
// under the mutex and acknowledge; they never wait.
#include <algorithm>

#include <functional>
#include <optional>
#include <string_view>
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/link/delivery_report.hpp"
#include "rgbdmap/proto/channels.hpp"

#include "robot_link_impl.hpp"

namespace rgbdmap {

template <typename T>
Status RobotLink::Impl::subscribe() {
  Result<std::string> channel = msg::channelFor(T::kType, options_.robot_id);
  if (!channel) return Status::failure(channel.error());
  std::weak_ptr<Impl> weak = weak_from_this();
  return transport_.subscribe(*channel, [weak](const std::string&, const uint8_t* data, size_t size) {
    if (std::shared_ptr<Impl> self = weak.lock()) self->onMessage<T>(data, size);
  });
}

Status RobotLink::Impl::subscribeAll() {
  for (Status s :
       {subscribe<msg::KeyframeAck>(), subscribe<msg::PoseCorrections>(), subscribe<msg::OccupancySlice>(),
        subscribe<msg::VelocityCommand>(), subscribe<msg::ServerStatus>()})
    if (!s) return Status::failure("RobotLink: subscribe: " + s.error());
  if (chunking())
    if (Status s = subscribe<msg::ChunkAck>(); !s)
      return Status::failure("RobotLink: subscribe: " + s.error());
  return Status::success();
}

template <typename T>
void RobotLink::Impl::onMessage(const uint8_t* data, size_t size) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    if constexpr (std::is_same_v<T, msg::VelocityCommand>) {
      const size_t hash =
          std::hash<std::string_view>()(std::string_view(reinterpret_cast<const char*>(data), size));
      if (std::find(own_commands_.begin(), own_commands_.end(), hash) != own_commands_.end())
        return;  // our echo
    }
  }
  bytes_received_ += size;
  if constexpr (std::is_same_v<T, msg::ServerStatus>) {
    if (readNotServedNotice(data, size)) return;
  }
  msg::RejectNote note;
  Result<msg::OpenedEnvelope> opened = msg::openEnvelope(data, size, keys_, &replay_guard_, &rejects_, &note);
  if (!opened) {  // counted and logged (rate-limited) by rejects_
    if constexpr (std::is_same_v<T, msg::ServerStatus>) {
      if (note.reason == msg::RejectReason::kBadSignature) readUnverifiedStatus(data, size);
    }
    return;
  }
  if (opened->header.sender != msg::kServerId) {  // open mode accepts any id: only the server talks to us
    rejects_.add(msg::RejectReason::kUnknownSender,
                 "robot " + options_.robot_id + " expects 'server', got '" + opened->header.sender + "'");
    return;
  }
  Result<T> message = msg::decodeMessage<T>(*opened, &rejects_);
  if (!message) return;
  if constexpr (!std::is_same_v<T, msg::ServerStatus>) {
    if (!isForMe(message->robot_id)) return;
  }
  // Every message but the status and a ChunkAck is addressed to a robot the server registered. A ChunkAck
  // answers chunks whatever the Hello: taking it for a registration stopped the Hello of a robot started
  // before its server, whose keyframes then waited for that Hello for good.
  bool knows_me = !std::is_same_v<T, msg::ChunkAck>;
  if constexpr (std::is_same_v<T, msg::ServerStatus>) {
    knows_me = false;
    for (const msg::RobotStatus& r : message->robots) knows_me = knows_me || r.robot_id == options_.robot_id;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    heard_from_server_ = true;
    server_knows_me_ = server_knows_me_ || knows_me;
  }
  handle(*message);
}

bool RobotLink::Impl::isForMe(const std::string& robot_id) {
  if (robot_id == options_.robot_id) return true;
  rejects_.add(msg::RejectReason::kInvalidContent,
               "message for robot '" + robot_id + "' on robot " + options_.robot_id + "'s channel");
  return false;
}

void RobotLink::Impl::handle(const msg::KeyframeAck& ack) {
  bool spooled = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_answer_ = Clock::now();
    auto it = sent_.find(ack.keyframe_id);
    if (it == sent_.end()) {
      ++counts_.unknown_acks;
      return;
    }
    SentKeyframe& entry = it->second;
    if (entry.answer != Answer::kPending) {
      ++counts_.duplicate_acks;
    } else {
      entry.answer = ack.accepted ? Answer::kAccepted : Answer::kRefused;
      entry.message.reset();
      if (entry.transfer.completed != Clock::time_point{}) {  // how long the server took to store it
        const double ms =
            std::chrono::duration<double, std::milli>(Clock::now() - entry.transfer.completed).count();
        store_ack_ms_ = store_ack_ms_ == 0.0 ? ms : 0.875 * store_ack_ms_ + 0.125 * ms;
      }
      entry.transfer = ChunkTransfer{};
      ++(ack.accepted ? counts_.keyframes_acked : counts_.keyframes_refused);
      if (entry.recovered) ++(ack.accepted ? counts_.recovered_acked : counts_.recovered_refused);
      spooled = entry.spooled;
      queue_.erase(ack.keyframe_id);
      if (ack.accepted) entry.accepted_utime = nowUtime();
      if (ack.accepted)
        ack_latency_ms_.add(
            std::chrono::duration<double, std::milli>(Clock::now() - entry.first_sent).count());
      if (!ack.accepted) {
        ++counts_.refused_by_reason[ack.reason.empty() ? "no reason given" : ack.reason];
        log::warn("robot ", options_.robot_id, ": server refused keyframe ", ack.keyframe_id, ": ",
                  ack.reason);
      }
    }
  }
  reliable_.acknowledge(static_cast<uint64_t>(ack.keyframe_id));  // no resend, whatever the answer
  if (spooled) noteAnswered(ack.keyframe_id);
  changed_.notify_all();
}

void RobotLink::Impl::handle(const msg::PoseCorrections& corrections) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    // A greater session is a restarted server: its revisions start again.
    if (corrections.header.session < corrections_session_ ||
        (corrections.header.session == corrections_session_ &&
         corrections.graph_revision <= graph_revision_)) {
      ++counts_.corrections_stale;
      return;
    }
    corrections_session_ = corrections.header.session;
    graph_revision_ = corrections.graph_revision;
    for (const msg::CorrectedPose& c : corrections.keyframes)
      if (sent_.count(c.keyframe_id)) T_map_cam_[c.keyframe_id] = c.T_map_cam;
    updateSegmentAnchors(corrections);
    ++counts_.corrections_received;
  }
  changed_.notify_all();
}

void RobotLink::Impl::updateSegmentAnchors(const msg::PoseCorrections& corrections) {
  // Per segment, the newest corrected keyframe k: T_map_odom = T_map_cam(k) * T_odom_cam(k)^-1. T_map_cam_
  // is ordered by id, so the last one seen per segment is the newest.
  std::map<int, SE3> anchors;
  for (const auto& [id, T_map_cam] : T_map_cam_) {
    const SentKeyframe& kf = sent_.at(id);
    anchors[kf.segment] = se3::normalized(T_map_cam * kf.T_odom_cam.inverse());
  }
  for (const auto& [segment, T] : anchors) T_map_odom_[segment] = T;
  // The message's own T_map_odom is for the segment of the newest keyframe the server holds; it fills in only
  // when none of that segment's keyframes is corrected yet. The robot takes the segment of its newest
  // accepted keyframe for it (the server stored that one; a newer one may still be in flight).
  for (auto it = sent_.rbegin(); it != sent_.rend(); ++it) {
    if (it->second.answer != Answer::kAccepted) continue;
    if (!anchors.count(it->second.segment)) T_map_odom_[it->second.segment] = corrections.T_map_odom;
    break;
  }
}

void RobotLink::Impl::handle(const msg::OccupancySlice& slice) {
  std::lock_guard<std::mutex> lock(mutex_);
  slice_ = slice;
  ++counts_.slices_received;
}

void RobotLink::Impl::handle(const msg::VelocityCommand& command) {
  std::lock_guard<std::mutex> lock(mutex_);
  command_ = command;
  ++counts_.commands_received;
}

void RobotLink::Impl::handle(const msg::ServerStatus& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const msg::RobotStatus& r : status.robots)  // a localising robot logs where it stands, once a change
    if (r.robot_id == options_.robot_id && r.localize && placed_ != r.placed) {
      placed_ = r.placed;
      log::info("robot ", options_.robot_id,
                r.placed ? ": placed in the stored map" : ": localising, not placed in the stored map yet");
    }
  status_ = status;
  ++counts_.status_received;
  noteServerRejects(status, true);
}

std::optional<msg::ServerStatus> RobotLink::Impl::unverifiedStatus(const uint8_t* data, size_t size) const {
  // No replay guard and no counters: nothing read here is trusted or acted on; it only words the diagnosis
  // and the delivery report of a robot that cannot verify the server (a wrong key on one side, or a server
  // that does not serve it and answers with an unsigned notice).
  Result<msg::OpenedEnvelope> opened = msg::openEnvelope(data, size, unverified_keys_, nullptr);
  if (!opened || opened->header.sender != msg::kServerId) return std::nullopt;
  Result<msg::ServerStatus> status = msg::decodeMessage<msg::ServerStatus>(*opened);
  if (!status) return std::nullopt;
  return std::move(*status);
}

void RobotLink::Impl::readUnverifiedStatus(const uint8_t* data, size_t size) {
  const std::optional<msg::ServerStatus> status = unverifiedStatus(data, size);
  if (!status) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!counts_.server_rejects_verified) noteServerRejects(*status, false);
}

bool RobotLink::Impl::readNotServedNotice(const uint8_t* data, size_t size) {
  // Read before the signature check, which it would fail (it is unsigned): not a rejection to count or log.
  const std::optional<msg::ServerStatus> status = unverifiedStatus(data, size);
  if (!status || !status->robots.empty()) return false;
  const bool notice =
      std::any_of(status->rejects.begin(), status->rejects.end(), [&](const msg::RejectCount& r) {
        return r.robot_id == options_.robot_id && isNotServedReason(r.reason);
      });
  if (!notice) return false;
  std::lock_guard<std::mutex> lock(mutex_);
  ++counts_.not_served_notices;
  if (!counts_.server_rejects_verified) noteServerRejects(*status, false);
  return true;
}

void RobotLink::Impl::noteServerRejects(const msg::ServerStatus& status, bool verified) {
  counts_.server_status_seen = true;
  counts_.server_rejects_verified = verified;
  counts_.server_rejects.clear();
  for (const msg::RejectCount& r : status.rejects)
    if (r.robot_id == options_.robot_id) counts_.server_rejects[r.reason] = r.count;
}

void RobotLink::Impl::diagnoseLink(Clock::time_point now) {
  constexpr double kDiagnoseAfterS = 3.0;
  const std::string& id = options_.robot_id;
  if (std::chrono::duration<double>(now - created_).count() < kDiagnoseAfterS) return;
  const uint64_t bad_here = rejects_.get(msg::RejectReason::kBadSignature);
  const auto reported = counts_.server_rejects.find("bad_signature");
  const int64_t bad_there = reported == counts_.server_rejects.end() ? 0 : reported->second;
  const std::string why_not_served = notServedReason(counts_);
  std::string cause = "no server heard";
  if (heard_from_server_)
    cause = "server heard";
  else if (!why_not_served.empty())
    cause = "not served by the server";
  else if (bad_here > 0 || bad_there > 0)
    cause = "keys differ";
  if (cause == counts_.diagnosis) return;
  const bool first = counts_.diagnosis.empty();
  counts_.diagnosis = cause;
  if (cause == "server heard") {
    if (!first) log::info("robot ", id, ": a server is heard now");
  } else if (cause == "not served by the server") {
    log::warn("robot ", id, ": the server does not serve robot id '", id, "': ", why_not_served,
              " (its unsigned notice, not verifiable here). Add '", id, "' to server.robots and its key to ",
              "server.keys_file (rgbdmap keys new ", id, "). Keyframes are kept and retried.");
  } else if (cause == "keys differ") {
    log::warn("robot ", id, ": a server is there but the keys differ: ", bad_here,
              " of its messages failed verification here",
              bad_there > 0 ? ", and it reports " + std::to_string(bad_there) + " messages from " + id +
                                  " with a bad signature"
                            : std::string(),
              ". Fix robot.key_file (--key-file) or the server's line for ", id,
              " in server.keys_file. Keyframes are kept and retried.");
  } else {
    log::warn("robot ", id, ": no server heard in ", kDiagnoseAfterS,
              " s. Check that rgbdmap-server runs on the same transport (URL; CYCLONEDDS_URI for DDS; the "
              "multicast route for LCM) and serves robot id '",
              id, "' (server.robots) with this robot's key. Keyframes are kept and retried.");
  }
}

}  // namespace rgbdmap
