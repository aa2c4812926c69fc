// Inbox: chunked keyframe transfers (udpm:// robots). Each chunk is an authenticated envelope of its own;
// the reassembled bytes are a keyframe envelope, opened and checked exactly like one that came whole. The
// last chunk of a burst (and the one that completes a transfer) gets a ChunkAck; a duplicate last chunk of a
// keyframe the ingest worker answered (a robot's probe for a KeyframeAck it did not get) gets that answer
// again as well.
#include "rgbdmap/intake/inbox.hpp"

namespace rgbdmap {

void Inbox::onChunk(const msg::OpenedEnvelope& opened, const std::string& robot) {
  auto chunk = decodeFrom<msg::KeyframeChunk>(opened, robot);
  if (!chunk) return;
  if (chunk->robot_id != robot)
    return reject(robot, msg::RejectReason::kInvalidContent,
                  "keyframe chunk for '" + chunk->robot_id + "' from " + robot);
  if (!chunk_ack_sink_)
    return reject(robot, msg::RejectReason::kWrongType,
                  "keyframe chunk from " + robot + " (chunks not enabled)");
  const auto now = ChunkReassembly::Clock::now();
  chunks_.evictStale(now);
  msg::Bytes envelope;
  const ChunkReassembly::Outcome outcome = chunks_.add(robot, *chunk, now, &envelope);
  if (outcome == ChunkReassembly::Outcome::kRefused)
    return reject(
        robot, msg::RejectReason::kInvalidContent,
        "keyframe chunk from " + robot + " contradicts its transfer or exceeds the reassembly bounds");
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
  if (outcome == ChunkReassembly::Outcome::kDuplicate) repeatAnswer(robot, *chunk, now);
}

void Inbox::noteAnswer(const std::string& robot, int64_t session, int keyframe_id, bool accepted,
                       const std::string& reason) {
  answers_.remember(robot, session, keyframe_id, accepted, reason, KeyframeAnswers::Clock::now());
}

void Inbox::repeatAnswer(const std::string& robot, const msg::KeyframeChunk& chunk,
                         ChunkReassembly::Clock::time_point now) {
  if (!keyframe_ack_sink_) return;
  // The chunks and the keyframe envelope are sealed in the same robot session.
  if (auto ack = answers_.repeat(robot, chunk.header.session, chunk.keyframe_id, now))
    keyframe_ack_sink_(robot, *ack);
}

void Inbox::onReassembled(const std::string& robot, const msg::Bytes& envelope) {
  msg::RejectNote note;
  auto opened = msg::openEnvelope(envelope, keys_, &guard_, &rejects_, &note);
  if (!opened) {  // counted and logged (rate-limited) by RejectCounters; the chunks' sender in the ledger
    ledger_.add(robot, RejectLedger::reasonKey(note.reason));
    return;
  }
  if (opened->header.sender != robot)
    return reject(robot, msg::RejectReason::kHeaderMismatch,
                  "sender '" + opened->header.sender + "' in chunks of " + robot);
  if (opened->type != msg::MessageType::kKeyframe)  // no chunks in chunks
    return reject(robot, msg::RejectReason::kWrongType,
                  std::string(msg::toString(opened->type)) + " in chunks of " + robot);
  onKeyframe(*opened, robot);
}

}  // namespace rgbdmap
