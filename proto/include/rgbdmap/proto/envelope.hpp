#pragma once
// The signed envelope: the unit that goes on the wire for every message (proto/lcm/envelope_t.lcm).
//
//   sender side:   Signer signer(id, key, session);  bytes = signer.seal(keyframe, utime);
//   receiver side: opened = openEnvelope(bytes, keys, &guard, &counters);
//                  keyframe = decodeMessage<msg::Keyframe>(*opened, &counters);
//
// Authentication: HMAC-SHA256 (OpenSSL libcrypto) with the sender's key over every encoded byte but the
// last 32 (the mac field, which the schema keeps last), compared in constant time. Keys are symmetric and
// per robot: robot R and the server share key_R; R signs with it as sender "R", the server signs what it
// sends to R with it as sender "server", so R's KeyStore maps "server" -> key_R.
//
// Replay: ReplayGuard keeps, per sender, the session and a 64-message sliding window below the highest seq
// seen, so reordered but fresh messages pass once and duplicates or anything older than the window fail.
// `session` is chosen by the sender once per process start (its start time in microseconds, see
// newSessionId()); a receiver accepts a new session only if it is greater than the one it holds, so a
// restarted robot is accepted at once while messages from an older session are rejected as replays.
// Limits: the guard lives in memory; after a *receiver* restart a recorded message of the sender's current
// session could be replayed once. A sender whose clock went backwards across a restart is refused until the
// receiver restarts.
//
// Open mode (KeyStore::openMode()) is for local demos only: senders without a key are accepted unsigned
// (ids, structure and replay are still checked; a sender that has a key must still sign correctly); it
// logs a warning when created. OpenedEnvelope::authenticated says which case applied.
#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::msg {

constexpr size_t kMacBytes = 32;
constexpr size_t kMinKeyBytes = 16;

enum class RejectReason : int {
  kTruncated = 0,  ///< too short, or a count/length runs past the end
  kTooLarge,       ///< above kMaxEnvelopeBytes
  kMalformed,      ///< not an envelope (type hash), trailing bytes
  kWrongSchemaVersion,
  kUnknownType,
  kInvalidSender,  ///< sender id fails the charset/length rule
  kUnknownSender,
  kBadSignature,
  kReplayedSeq,     ///< duplicate, older than the window, or an older session
  kWrongType,       ///< decodeMessage<T> on an envelope of another type
  kHeaderMismatch,  ///< message header differs from the envelope's
  kInvalidContent,  ///< the payload failed decoding or validation
  kCount
};
const char* toString(RejectReason reason);

/// Per-reason counters for the server to report, plus one rate-limited warning line per rejection
/// (at most `log_per_second`; the next line that passes says how many were suppressed). Thread-safe.
class RejectCounters {
 public:
  explicit RejectCounters(double log_per_second = 1.0) : limiter_(log_per_second) {}
  void add(RejectReason reason, const std::string& detail = "");
  uint64_t get(RejectReason reason) const { return counts_[static_cast<int>(reason)].load(); }
  uint64_t total() const;

 private:
  std::array<std::atomic<uint64_t>, static_cast<int>(RejectReason::kCount)> counts_{};
  log::RateLimiter limiter_;
};

/// Sender id -> HMAC key. Not thread-safe for writes; fill it at start-up, then share it read-only.
class KeyStore {
 public:
  KeyStore() = default;
  /// Accepts unsigned messages from anyone; logs a warning. For local demos only (warn = false: for reading
  /// a message that failed verification as an unverified diagnostic hint, never to act on it).
  static KeyStore openMode(bool warn = true);
  /// Fails for an invalid id or a key shorter than kMinKeyBytes.
  Status add(const std::string& sender, const Bytes& key);
  const Bytes* find(const std::string& sender) const;
  bool isOpen() const { return open_; }
  size_t size() const { return keys_.size(); }

 private:
  std::map<std::string, Bytes> keys_;
  bool open_ = false;
};

/// A new random 32-byte key (OpenSSL's RAND_bytes); the reason when the generator fails.
Result<Bytes> newKey();
/// Bytes as lower-case hex digits (a key as the keys files hold it).
std::string toHex(const Bytes& bytes);

/// Hex string (64 hex digits for 32 bytes, any even length >= 2 * kMinKeyBytes) -> key bytes.
Result<Bytes> parseHexKey(const std::string& hex);

/// Reads `robot_id hexkey` lines ('#' comments, blank lines ignored) into `keys` (e.g. an open-mode store,
/// where robots with a key must then still sign).
Result<KeyStore> readKeysFile(const std::string& path, KeyStore keys = {});

/// Sliding-window replay protection per sender. Thread-safe.
class ReplayGuard {
 public:
  static constexpr int kWindow = 64;
  /// At most `max_senders` senders are remembered; a new one beyond that is refused ("too many senders")
  /// rather than evicting one (eviction would re-open that sender to replays). Matters in open mode, where
  /// anyone may claim a new sender id; with keys, the KeyStore bounds the senders already.
  explicit ReplayGuard(size_t max_senders = 1024) : max_senders_(max_senders) {}
  /// Accepts (and records) the header if its (session, seq) has not been seen in `stream`; else the reason.
  /// Windows are kept per (sender, stream); openEnvelope uses the message type as the stream, so a late
  /// joiner's old "latest" map is not refused because newer status messages arrived first.
  Status check(const Header& header, int stream = 0);

 private:
  struct State {
    int64_t session = 0;
    int64_t highest = -1;
    uint64_t window = 0;  ///< bit i: seq (highest - i) seen
  };
  std::mutex mutex_;
  std::map<std::string, State> senders_;
  size_t max_senders_;
};

struct OpenedEnvelope {
  MessageType type = MessageType::kHello;
  Header header;
  Bytes payload;
  bool authenticated = false;  ///< false only in open mode
};

/// What openEnvelope saw of a message it rejected: the reason and the sender id the message claims (its
/// header's sender, unverified and possibly not a valid id; empty when the header could not be decoded).
struct RejectNote {
  RejectReason reason = RejectReason::kCount;
  std::string claimed_sender;
};

/// Builds and signs an envelope (mac all zero when `key` is empty: open mode only).
Result<Bytes> encodeEnvelope(MessageType type, const Header& header, const Bytes& payload, const Bytes& key);

/// Checks size, structure, schema version, type, sender id, key, signature and replay, in that order, and
/// counts each rejection in `counters` (optional). The replay window is updated only for authentic messages.
/// On a rejection, `note` (optional) receives the reason and the claimed sender.
Result<OpenedEnvelope> openEnvelope(const uint8_t* data, size_t size, const KeyStore& keys,
                                    ReplayGuard* guard, RejectCounters* counters = nullptr,
                                    RejectNote* note = nullptr);
inline Result<OpenedEnvelope> openEnvelope(const Bytes& bytes, const KeyStore& keys, ReplayGuard* guard,
                                           RejectCounters* counters = nullptr, RejectNote* note = nullptr) {
  return openEnvelope(bytes.data(), bytes.size(), keys, guard, counters, note);
}

/// Decodes and validates the payload as T; checks the type and that its header equals the envelope's.
template <typename T>
Result<T> decodeMessage(const OpenedEnvelope& envelope, RejectCounters* counters = nullptr) {
  auto reject = [counters](RejectReason reason, const std::string& detail) {
    if (counters) counters->add(reason);
    return Result<T>::failure(detail.empty() ? toString(reason)
                                             : std::string(toString(reason)) + ": " + detail);
  };
  if (envelope.type != T::kType) return reject(RejectReason::kWrongType, toString(envelope.type));
  Result<T> message = decodePayload<T>(envelope.payload);
  if (!message) return reject(RejectReason::kInvalidContent, message.error());
  if (!(message->header == envelope.header)) return reject(RejectReason::kHeaderMismatch, "");
  return message;
}

/// Start time in microseconds (system clock): a session id that grows across restarts.
int64_t newSessionId();

/// Stamps headers (sender, session, seq, utime) and signs. One per sending process; not thread-safe.
class Signer {
 public:
  /// An empty key sends unsigned messages (accepted only by an open-mode receiver). A sender resuming an
  /// earlier session starts its seq above every one that session used (`first_seq`).
  Signer(std::string sender, Bytes key, int64_t session = newSessionId(), int64_t first_seq = 0);

  /// Sets message.header, validates, encodes and signs. seq advances only on success.
  template <typename T>
  Result<Bytes> seal(T message, int64_t utime) {
    message.header = Header{kSchemaVersion, sender_, session_, next_seq_, utime};
    Result<Bytes> payload = encodePayload(message);
    if (!payload) return Result<Bytes>::failure(payload.error());
    Result<Bytes> out = encodeEnvelope(T::kType, message.header, *payload, key_);
    if (out) ++next_seq_;
    return out;
  }
  int64_t nextSeq() const { return next_seq_; }
  const std::string& sender() const { return sender_; }

 private:
  std::string sender_;
  Bytes key_;
  int64_t session_;
  int64_t next_seq_;
};

}  // namespace rgbdmap::msg
