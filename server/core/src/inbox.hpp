#pragma once
// The server's inbox, on the transport's receive thread: channel -> authenticate (signature, replay) ->
// decode -> check the sender -> queue for the ingest worker. Never blocks on the worker. A keyframe over
// its robot's rate (KeyframeThrottle) is dropped before its payload is decoded; one that does not fit its
// robot's queue after decoding; both unacknowledged (the robot resends) and counted per robot (throttled,
// queue_full). A retransmission of a keyframe still queued is dropped and counted (duplicates_queued).
// Rejections are counted (and logged, rate-limited) by RejectCounters.
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "chunk_reassembly.hpp"
#include "keyframe_throttle.hpp"
#include "reject_ledger.hpp"
#include "rgbdmap/ingest/ingest_queue.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/server/map_server_config.hpp"
#include "robot_registry.hpp"

namespace rgbdmap {

class Inbox {
 public:
  /// References must outlive the inbox.
  Inbox(const MapServerConfig& config, const msg::KeyStore& keys, RobotRegistry& registry,
        IngestQueue& queue);

  /// A transport handler (one call at a time, on the receive thread).
  void onMessage(const std::string& channel, const uint8_t* data, size_t size);

  /// Where ChunkAcks go (the server's RobotPublisher); chunked keyframes are refused without one.
  using ChunkAckSink = std::function<void(const std::string& robot, const msg::ChunkAck& ack)>;
  void setChunkAckSink(ChunkAckSink sink) { chunk_ack_sink_ = std::move(sink); }

  uint64_t rejected() const { return rejects_.total(); }
  uint64_t unknownRobot() const { return unknown_robot_.load(); }
  uint64_t throttled() const { return throttled_.load(); }
  uint64_t queueFull() const { return queue_full_.load(); }
  uint64_t duplicatesQueued() const { return duplicates_queued_.load(); }
  /// Rejections per claimed robot and reason (RejectLedger; "" = not a known robot), largest first.
  std::vector<msg::RejectCount> rejectCounts() const { return ledger_.counts(); }

 private:
  bool admitted(const std::string& robot) const;  ///< in config.robots (or the list is empty)
  void onHello(const msg::OpenedEnvelope& opened, const std::string& robot);
  void onKeyframe(const msg::OpenedEnvelope& opened, const std::string& robot);
  void countQueueFull(const std::string& robot);
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
  void onChunk(const msg::OpenedEnvelope& opened, const std::string& robot);  ///< inbox_chunks.cpp
  void onReassembled(const std::string& robot, const msg::Bytes& envelope);

  const MapServerConfig& config_;
  const msg::KeyStore& keys_;
  RobotRegistry& registry_;
  IngestQueue& queue_;
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
};

}  // namespace rgbdmap
