#include "rgbdmap/intake/inbox.hpp"

#include <algorithm>
#include <chrono>
#include <utility>

#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap {

Inbox::Inbox(InboxConfig config, const msg::KeyStore& keys, RobotRegistry& registry, InboxQueue queue)
    : config_(std::move(config)),
      keys_(keys),
      registry_(registry),
      queue_(std::move(queue)),
      throttle_(config_.max_keyframes_per_s, config_.keyframe_burst),
      ledger_(RejectLedgerOptions{}, [this](const std::string& robot) { return known(robot); }),
      answers_(config_.answers) {}

void Inbox::onMessage(const std::string& channel, const uint8_t* data, size_t size) {
  std::string robot, suffix;
  if (!msg::splitChannel(channel, &robot, &suffix)) return;
  const bool to_server = suffix == msg::channelSuffix(msg::MessageType::kHello) ||
                         suffix == msg::channelSuffix(msg::MessageType::kHeartbeat) ||
                         suffix == msg::channelSuffix(msg::MessageType::kKeyframe) ||
                         suffix == msg::channelSuffix(msg::MessageType::kKeyframeChunk);
  if (!to_server) return;  // our own messages (udpm:// loops them back under a "rgbdmap/*" subscription)
  msg::RejectNote note;
  auto opened = msg::openEnvelope(data, size, keys_, &guard_, &rejects_, &note);
  if (!opened) {  // counted and logged (rate-limited) by RejectCounters, and by claimed sender here
    ledger_.add(note.claimed_sender.empty() ? robot : note.claimed_sender,
                RejectLedger::reasonKey(note.reason));
    if (note.reason == msg::RejectReason::kUnknownSender && note.claimed_sender == robot)
      notServed(robot, admitted(robot) ? RejectLedger::reasonKey(note.reason) : "unknown_robot");
    return;
  }
  if (opened->header.sender != robot) {
    reject(opened->header.sender, msg::RejectReason::kHeaderMismatch,
           "sender '" + opened->header.sender + "' on " + channel, "on " + channel);
    return;
  }
  if (!admitted(robot)) {
    ++unknown_robot_;
    ledger_.add(robot, "unknown_robot", "not in the server's robot list");
    notServed(robot, "unknown_robot");
    return;
  }
  registry_.addBytesReceived(robot, size, opened->header.utime);
  switch (opened->type) {
    case msg::MessageType::kHello:
      return onHello(*opened, robot);
    case msg::MessageType::kHeartbeat:
      if (auto heartbeat = decodeFrom<msg::Heartbeat>(*opened, robot);
          heartbeat && heartbeat->robot_id == robot)
        registry_.noteHeartbeat(*heartbeat, std::chrono::steady_clock::now());
      return;
    case msg::MessageType::kKeyframe:
      return onKeyframe(*opened, robot);
    case msg::MessageType::kKeyframeChunk:
      return onChunk(*opened, robot);
    default:
      return reject(robot, msg::RejectReason::kWrongType,
                    std::string(msg::toString(opened->type)) + " on " + channel);
  }
}

InboxStats Inbox::stats() const {
  InboxStats s;
  s.messages_rejected = rejects_.total();
  s.unknown_robot_messages = unknown_robot_.load();
  s.keyframes_dropped_queue_full = queue_full_.load();
  s.keyframes_duplicates_queued = duplicates_queued_.load();
  s.keyframes_throttled = throttled_.load();
  s.rejects = ledger_.counts();
  s.refusal_notices_sent = notices_.sent();
  s.keyframe_acks_repeated = answers_.repeated();
  return s;
}

bool Inbox::known(const std::string& robot) const {
  return admitted(robot) && (keys_.find(robot) != nullptr || registry_.index(robot) >= 0);
}

bool Inbox::admitted(const std::string& robot) const {
  return config_.robots.empty() ||
         std::find(config_.robots.begin(), config_.robots.end(), robot) != config_.robots.end();
}

void Inbox::onHello(const msg::OpenedEnvelope& opened, const std::string& robot) {
  auto hello = decodeFrom<msg::Hello>(opened, robot);
  if (!hello) return;
  if (hello->robot_id != robot)
    return reject(robot, msg::RejectReason::kInvalidContent,
                  "hello for '" + hello->robot_id + "' from " + robot);
  queue_.hello(std::move(*hello));
}

void Inbox::onKeyframe(const msg::OpenedEnvelope& opened, const std::string& robot) {
  // Authentic, not decoded yet: over the robot's rate costs nothing more. Within it, the message is decoded
  // before its queue is asked for room, so that a retransmission of a keyframe still queued is told from a
  // new one (RobotQueues): only a new one that does not fit counts as queue_full and demotes the robot.
  if (!throttle_.allow(robot, KeyframeThrottle::Clock::now())) {
    ++throttled_;
    return countOverShare(robot, RobotRegistry::KeyframeOutcome::kThrottled);
  }
  const size_t bytes = opened.payload.size();
  auto keyframe = decodeFrom<msg::Keyframe>(opened, robot);
  if (!keyframe) return;
  if (keyframe->robot_id != robot)
    return reject(robot, msg::RejectReason::kInvalidContent,
                  "keyframe for '" + keyframe->robot_id + "' from " + robot);
  switch (queue_.keyframe(std::move(*keyframe), bytes)) {
    case RobotQueues::Pushed::kFull:
      ++queue_full_;
      return countOverShare(robot, RobotRegistry::KeyframeOutcome::kQueueFull);
    case RobotQueues::Pushed::kDuplicate:
      ++duplicates_queued_;
      return registry_.recordKeyframe(robot, RobotRegistry::KeyframeOutcome::kDuplicateQueued);
    case RobotQueues::Pushed::kQueued:
      return;
  }
}

void Inbox::reject(const std::string& robot, msg::RejectReason reason, const std::string& detail,
                   const std::string& ledger_detail) {
  rejects_.add(reason, detail);
  ledger_.add(robot, RejectLedger::reasonKey(reason), ledger_detail);
}

void Inbox::notServed(const std::string& robot, const std::string& reason) {
  if (!notice_sink_) return;
  if (std::optional<msg::ServerStatus> notice = notices_.refused(robot, reason)) notice_sink_(robot, *notice);
}

void Inbox::countOverShare(const std::string& robot, RobotRegistry::KeyframeOutcome outcome) {
  registry_.recordKeyframe(robot, outcome);
  queue_.demote(robot);
}

}  // namespace rgbdmap
