// Inbox: chunked keyframe transfers (udpm:// robots). Each chunk is an authenticated envelope of its own;
// the reassembled bytes are a keyframe envelope, opened and checked exactly like one that came whole.
#include "inbox.hpp"

namespace rgbdmap {

void Inbox::onChunk(const msg::OpenedEnvelope& opened, const std::string& robot) {
  auto chunk = msg::decodeMessage<msg::KeyframeChunk>(opened, &rejects_);
  if (!chunk) return;
  if (chunk->robot_id != robot) {
    rejects_.add(msg::RejectReason::kInvalidContent,
                 "keyframe chunk for '" + chunk->robot_id + "' from " + robot);
    return;
  }
  if (!chunk_ack_sink_) {
    rejects_.add(msg::RejectReason::kWrongType, "keyframe chunk from " + robot + " (chunks not enabled)");
    return;
  }
  const auto now = ChunkReassembly::Clock::now();
  chunks_.evictStale(now);
  msg::Bytes envelope;
  const ChunkReassembly::Outcome outcome = chunks_.add(robot, *chunk, now, &envelope);
  if (outcome == ChunkReassembly::Outcome::kRefused) {
    rejects_.add(
        msg::RejectReason::kInvalidContent,
        "keyframe chunk from " + robot + " contradicts its transfer or exceeds the reassembly bounds");
    return;
  }
  if (outcome == ChunkReassembly::Outcome::kComplete) onReassembled(robot, envelope);
  if (!chunk->last_of_burst && outcome != ChunkReassembly::Outcome::kComplete) return;
  const auto bitmap = chunks_.receivedBitmap(robot, chunk->transfer_id);
  if (!bitmap) return;
  msg::ChunkAck ack;
  ack.robot_id = robot;
  ack.transfer_id = chunk->transfer_id;
  ack.keyframe_id = chunk->keyframe_id;
  ack.chunk_count = chunk->chunk_count;
  ack.received = *bitmap;
  chunk_ack_sink_(robot, ack);
}

void Inbox::onReassembled(const std::string& robot, const msg::Bytes& envelope) {
  auto opened = msg::openEnvelope(envelope, keys_, &guard_, &rejects_);
  if (!opened) return;  // counted and logged (rate-limited) by RejectCounters
  if (opened->header.sender != robot) {
    rejects_.add(msg::RejectReason::kHeaderMismatch,
                 "sender '" + opened->header.sender + "' in chunks of " + robot);
    return;
  }
  if (opened->type != msg::MessageType::kKeyframe) {  // no chunks in chunks
    rejects_.add(msg::RejectReason::kWrongType,
                 std::string(msg::toString(opened->type)) + " in chunks of " + robot);
    return;
  }
  onKeyframe(*opened, robot);
}

}  // namespace rgbdmap
