#pragma once
// The server's inbox, on the transport's receive thread: channel -> authenticate (signature, replay) ->
// decode -> check the sender -> queue for the ingest worker. Never blocks on the worker. A keyframe over
// its robot's rate (KeyframeThrottle) is dropped before its payload is decoded; one that does not fit its
// robot's queue after decoding; both unacknowledged (the robot resends) and counted per robot (throttled,
// queue_full). A retransmission of a keyframe still queued is dropped and counted (duplicates_queued).
// A duplicate last-of-burst chunk of a keyframe the ingest worker answered gets that KeyframeAck again
// (KeyframeAnswers).
// Rejections are counted (and logged, rate-limited) by RejectCounters. The queue behind it (the server's
// ingest queue) is given as an InboxQueue of three calls.
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "rgbdmap/intake/chunk_reassembly.hpp"
#include "rgbdmap/intake/intake_stats.hpp"
#include "rgbdmap/intake/keyframe_answers.hpp"
#include "rgbdmap/intake/keyframe_throttle.hpp"
#include "rgbdmap/intake/refusal_notices.hpp"
#include "rgbdmap/intake/reject_ledger.hpp"
#include "rgbdmap/intake/robot_queues.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap {

struct InboxConfig {
  /// server.robots: the robots served (empty: any robot the KeyStore admits).
  std::vector<std::string> robots;
  double max_keyframes_per_s = 30.0;  ///< server.robot_max_keyframes_per_s (KeyframeThrottle; 0: off)
  double keyframe_burst = 256.0;      ///< server.robot_keyframe_burst
  KeyframeAnswersOptions answers;     ///< the answers repeated for duplicate chunks (no config key)
};

/// Where the inbox hands what it accepted.
struct InboxQueue {
  std::function<void(msg::Hello)> hello;
  /// `bytes`: the keyframe's encoded size. kFull: not queued (counted as queue_full, the robot demoted);
  /// kDuplicate: the same keyframe is queued already (counted as duplicates_queued).
  std::function<RobotQueues::Pushed(msg::Keyframe, size_t bytes)> keyframe;
  /// `robot` went over its share (throttled, or its queue was full).
  std::function<void(const std::string& robot)> demote;
};

class Inbox {
 public:
  /// References must outlive the inbox.
  Inbox(InboxConfig config, const msg::KeyStore& keys, RobotRegistry& registry, InboxQueue queue);

  /// A transport handler (one call at a time, on the receive thread).
  void onMessage(const std::string& channel, const uint8_t* data, size_t size);

  /// Where ChunkAcks go (the server's RobotPublisher); chunked keyframes are refused without one.
  using ChunkAckSink = std::function<void(const std::string& robot, const msg::ChunkAck& ack)>;
  void setChunkAckSink(ChunkAckSink sink) { chunk_ack_sink_ = std::move(sink); }
  /// Where the KeyframeAcks repeated for duplicate chunks go (the server's RobotPublisher); none without one.
  using KeyframeAckSink = std::function<void(const std::string& robot, const msg::KeyframeAck& ack)>;
  void setKeyframeAckSink(KeyframeAckSink sink) { keyframe_ack_sink_ = std::move(sink); }
  /// The ingest worker answered keyframe `keyframe_id` of `robot`'s process `session` (any thread): from now
  /// on a duplicate last-of-burst chunk of it gets that answer again, at most every
  /// answers.repeat_interval_s.
  void noteAnswer(const std::string& robot, int64_t session, int keyframe_id, bool accepted,
                  const std::string& reason);
  /// Where the notices to robots the server does not serve go (RefusalNotices: unsigned); none without one.
  using NoticeSink = std::function<void(const std::string& robot, const msg::ServerStatus& notice)>;
  void setNoticeSink(NoticeSink sink) { notice_sink_ = std::move(sink); }

  /// Its counters now (any thread).
  InboxStats stats() const;
  /// Rejections per claimed robot and reason (RejectLedger; "" = not a known robot), largest first.
  std::vector<msg::RejectCount> rejectCounts() const { return ledger_.counts(); }

 private:
  bool admitted(const std::string& robot) const;  ///< in config_.robots (or the list is empty)
  void onHello(const msg::OpenedEnvelope& opened, const std::string& robot);
  void onKeyframe(const msg::OpenedEnvelope& opened, const std::string& robot);
  void countOverShare(const std::string& robot, RobotRegistry::KeyframeOutcome outcome);
  bool known(const std::string& robot) const;  ///< admitted and holds a key or said Hello
  /// Counts a rejected message in RejectCounters (totals, rate-limited log) and, for the claimed robot, in
  /// the ledger (ServerStatus::rejects).
  void reject(const std::string& robot, msg::RejectReason reason, const std::string& detail,
              const std::string& ledger_detail = "");
  /// msg::decodeMessage, a failure counted for `robot` in the ledger as well.
  template <typename T>
  Result<T> decodeFrom(const msg::OpenedEnvelope& opened, const std::string& robot) {
    Result<T> message = msg::decodeMessage<T>(opened, &rejects_);
    if (!message) ledger_.add(robot, RejectLedger::reasonKeyOf(message.error()));
    return message;
  }
  /// A message of `robot` refused because the server does not serve it: counted, and a notice when due.
  void notServed(const std::string& robot, const std::string& reason);
  void onChunk(const msg::OpenedEnvelope& opened, const std::string& robot);  ///< inbox_chunks.cpp
  void onReassembled(const std::string& robot, const msg::Bytes& envelope);
  void repeatAnswer(const std::string& robot, const msg::KeyframeChunk& chunk,
                    ChunkReassembly::Clock::time_point now);

  const InboxConfig config_;
  const msg::KeyStore& keys_;
  RobotRegistry& registry_;
  const InboxQueue queue_;
  msg::ReplayGuard guard_;
  msg::RejectCounters rejects_;
  std::atomic<uint64_t> unknown_robot_{0};
  KeyframeThrottle throttle_;
  std::atomic<uint64_t> throttled_{0};
  std::atomic<uint64_t> queue_full_{0};
  std::atomic<uint64_t> duplicates_queued_{0};
  RejectLedger ledger_;
  ChunkReassembly chunks_;
  ChunkAckSink chunk_ack_sink_;
  KeyframeAnswers answers_;
  KeyframeAckSink keyframe_ack_sink_;
  RefusalNotices notices_;
  NoticeSink notice_sink_;
};

}  // namespace rgbdmap
