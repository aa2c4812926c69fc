// RobotLink: keyframes in chunks (udpm://). A transfer is one sealed keyframe envelope cut into
// KeyframeChunks that each fit one datagram; the server answers each chunk flagged last-of-burst (the last
// three of a burst) and a completed transfer with a ChunkAck bitmap, and the missing chunks it shows lost
// (sent before a chunk that arrived) are sent again. The ReliableSender
// still drives retransmission when no answer comes: it resends what is missing; when every chunk arrived but
// no KeyframeAck did, it probes with the transfer's last chunk (the server answers a stored keyframe's
// duplicate chunk with its KeyframeAck again) and, much later, seals a new transfer (the server may have
// refused to queue the keyframe, or restarted and forgotten the transfer).
#include <algorithm>
#include <cmath>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/proto/chunking.hpp"
#include "robot_link_impl.hpp"

namespace rgbdmap {
namespace {

/// Every chunk arrived but no KeyframeAck (lost, or the server did not queue the keyframe): a new transfer
/// only after this many times the usual wait for the server to store it, and at least kMinResealWait; the
/// wait doubles with each new transfer of the same keyframe, up to kMaxResealWait (a server that cannot
/// store, e.g. on a full disk, is not flooded with whole keyframes every half second).
constexpr double kResealAfterStoreAcks = 4.0;
constexpr std::chrono::milliseconds kMinResealWait{500};
constexpr std::chrono::milliseconds kMaxResealWait{8000};
constexpr int kMaxAckRounds = 16;  ///< resends answering ChunkAcks per transfer
/// The last chunks of a burst flagged last-of-burst, each answered by a ChunkAck: a burst goes unanswered
/// (and waits for a timeout) only when all of them or all their answers are lost.
constexpr size_t kFlaggedChunks = 3;

std::vector<int> missingChunks(const std::vector<bool>& received) {
  std::vector<int> out;
  for (size_t i = 0; i < received.size(); ++i)
    if (!received[i]) out.push_back(static_cast<int>(i));
  return out;
}

}  // namespace

constexpr int kUdpmChunkBytes = 1100;  ///< one datagram at MTU 1500 even for a 32-character robot id
static_assert(kUdpmChunkBytes >= msg::kMinChunkBytes, "chunk size");

/// The earliest resend of a keyframe on a transport that repairs losses itself.
constexpr std::chrono::milliseconds kRepairedFirstResend{1000};

int resolveChunkBytes(int configured, const std::string& transport_url) {
  if (configured >= 0) return configured;
  // LCM splits a large message into datagrams and loses all of it with any one of them; DDS retransmits
  // lost fragments itself, memq:// loses nothing.
  return transport_url.rfind("udpm://", 0) == 0 ? kUdpmChunkBytes : 0;
}

transport::ReliableSenderOptions RobotLink::Impl::senderOptions(const RobotLinkOptions& options,
                                                                bool repairs_loss) {
  transport::ReliableSenderOptions out = options.reliable;
  if (repairs_loss) {
    // DDS repairs a lost fragment in tens of milliseconds, a keyframe under 30 % loss within about a
    // second; an earlier resend only adds a whole keyframe to the repairs (docs/results.md, Faults). A
    // resend is for what DDS cannot repair: a subscriber that restarted.
    out.initial_backoff = std::max(out.initial_backoff, kRepairedFirstResend);
    out.min_backoff = std::max(out.min_backoff, kRepairedFirstResend);
    out.max_backoff = std::max(out.max_backoff, out.initial_backoff);
  }
  // A burst goes unanswered when its flagged chunks or their ChunkAcks are lost, independently of the
  // other keyframes' bursts: one keyframe's backoff does not lengthen the others' timeouts.
  if (options.chunk_bytes > 0) out.shared_backoff = false;
  return out;
}

RobotLink::Impl::Clock::duration RobotLink::Impl::resealAfter(int reseals) const {
  const double ms = std::max<double>(kMinResealWait.count(), kResealAfterStoreAcks * store_ack_ms_) *
                    std::ldexp(1.0, std::min(reseals, 8));
  return std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double, std::milli>(std::min<double>(ms, kMaxResealWait.count())));
}

Status RobotLink::Impl::transmitChunked(int keyframe_id) {
  std::shared_ptr<const msg::Bytes> envelope;
  int64_t transfer_id = -1;
  std::vector<int> missing;
  msg::Keyframe copy;
  bool probe = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sent_.find(keyframe_id);
    if (it == sent_.end() || it->second.answer != Answer::kPending) return Status::success();
    SentKeyframe& entry = it->second;
    ++entry.transmissions;
    if (entry.transfer.envelope) missing = missingChunks(entry.transfer.received);
    // Every chunk arrived: the KeyframeAck usually follows once the server stored the keyframe. Until it is
    // much later than usual, the last chunk again asks for it (one datagram: a lost ack costs no transfer);
    // then a new transfer (the server did not queue the keyframe, or forgot the transfer).
    if (entry.transfer.envelope && missing.empty() &&
        Clock::now() - entry.transfer.completed < resealAfter(entry.reseals)) {
      probe = true;
      missing = {static_cast<int>(entry.transfer.received.size()) - 1};
    }
    if (!missing.empty()) {
      envelope = entry.transfer.envelope;
      transfer_id = entry.transfer.transfer_id;
      counts_.chunks_resent += missing.size();
    } else {
      if (!entry.message) return Status::success();
      copy = *entry.message;
      const int max_attempts = options_.reliable.max_attempts;
      if (entry.transmissions >= max_attempts && max_attempts > 0) entry.message.reset();
    }
  }
  if (!envelope) {  // a new transfer: seal afresh (the server's replay guard refuses a sealed copy twice)
    Result<msg::Bytes> bytes = [&] {
      std::lock_guard<std::mutex> lock(keyframe_signer_mutex_);
      transfer_id = keyframe_signer_.nextSeq();
      return keyframe_signer_.seal(copy, nowUtime());
    }();
    if (!bytes) return Status::failure("seal Keyframe: " + bytes.error());
    const int count = msg::chunkCount(bytes->size(), options_.chunk_bytes);
    if (count == 0)
      return Status::failure("keyframe of " + std::to_string(bytes->size()) + " bytes cannot be chunked");
    envelope = std::make_shared<const msg::Bytes>(std::move(*bytes));
    missing.resize(static_cast<size_t>(count));
    for (int i = 0; i < count; ++i) missing[static_cast<size_t>(i)] = i;
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sent_.find(keyframe_id);
    if (it == sent_.end() || it->second.answer != Answer::kPending) return Status::success();
    if (it->second.transfer.envelope) ++it->second.reseals;
    ChunkTransfer& transfer = it->second.transfer;
    transfer = ChunkTransfer{};
    transfer.envelope = envelope;
    transfer.transfer_id = transfer_id;
    transfer.received.assign(static_cast<size_t>(count), false);
    transfer.sent_seq.assign(static_cast<size_t>(count), 0);
  }
  // A probe's ChunkAck is no progress: unanswered probes back off like any retransmission.
  return sendChunks(keyframe_id, envelope, transfer_id, missing, probe);
}

Status RobotLink::Impl::sendChunks(int keyframe_id, const std::shared_ptr<const msg::Bytes>& envelope,
                                   int64_t transfer_id, const std::vector<int>& indices, bool probe) {
  {  // numbered before they go out: a ChunkAck may come back before the burst ends
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = sent_.find(keyframe_id);
    if (it != sent_.end() && it->second.transfer.transfer_id == transfer_id) {
      ChunkTransfer& transfer = it->second.transfer;
      transfer.burst_first = transfer.sends + 1;
      for (const int i : indices) transfer.sent_seq[static_cast<size_t>(i)] = ++transfer.sends;
      transfer.burst_sent = Clock::now();
      transfer.burst_answered = probe;
    }
  }
  Status result = Status::success();
  uint64_t sent = 0;
  const size_t flagged_from = indices.size() - std::min(indices.size(), kFlaggedChunks);
  for (size_t k = 0; k < indices.size(); ++k) {
    Result<msg::KeyframeChunk> chunk = msg::makeChunk(*envelope, options_.chunk_bytes, indices[k],
                                                      options_.robot_id, keyframe_id, transfer_id);
    if (!chunk) return Status::failure(chunk.error());
    chunk->last_of_burst = k >= flagged_from;
    if (Status s = sealAndPublish(*chunk, chunk_channel_); !s) {
      result = s;  // the rest still goes out; the server reports what is missing
    } else {
      ++sent;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  counts_.chunks_sent += sent;
  return result;
}

void RobotLink::Impl::handle(const msg::ChunkAck& ack) {
  std::shared_ptr<const msg::Bytes> envelope;
  std::vector<int> missing;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counts_.chunk_acks;
    last_answer_ = Clock::now();
    auto it = sent_.find(ack.keyframe_id);
    if (it == sent_.end() || it->second.answer != Answer::kPending) return;
    ChunkTransfer& transfer = it->second.transfer;
    if (!transfer.envelope || transfer.transfer_id != ack.transfer_id ||
        transfer.received.size() != static_cast<size_t>(ack.chunk_count))
      return;             // an older transfer of this keyframe, or not ours
    uint32_t newest = 0;  // the latest chunk send this ChunkAck shows received
    for (size_t i = 0; i < transfer.received.size(); ++i) {
      if (!msg::chunkReceived(ack.received, static_cast<int>(i))) continue;
      transfer.received[i] = true;
      newest = std::max(newest, transfer.sent_seq[i]);
    }
    const bool answers_burst = !transfer.burst_answered && newest >= transfer.burst_first;
    if (answers_burst) {  // the server is there: the next timeout restarts from the RTO
      transfer.burst_answered = true;
      reliable_.progress(static_cast<uint64_t>(ack.keyframe_id), Clock::now() - transfer.burst_sent);
    }
    missing = missingChunks(transfer.received);
    if (missing.empty()) {  // the KeyframeAck follows once the server stored it
      if (transfer.completed == Clock::time_point{}) transfer.completed = Clock::now();
      return;
    }
    // Chunks arrive in the order sent: a missing chunk sent before the newest one received is lost. One
    // sent after it may still be on its way (this ChunkAck may answer an earlier flagged chunk); the
    // next ChunkAck or the timeout tells.
    missing.erase(std::remove_if(missing.begin(), missing.end(),
                                 [&](int i) { return transfer.sent_seq[static_cast<size_t>(i)] > newest; }),
                  missing.end());
    if (missing.empty()) return;
    if (++transfer.ack_rounds > kMaxAckRounds) return;  // no ping-pong with a server that keeps refusing
    envelope = transfer.envelope;
    counts_.chunks_resent += missing.size();
  }
  if (Status s = sendChunks(ack.keyframe_id, envelope, ack.transfer_id, missing); !s)
    log::debug("robot ", options_.robot_id, ": resending chunks of keyframe ", ack.keyframe_id, ": ",
               s.error());
}

}  // namespace rgbdmap
