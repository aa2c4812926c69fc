#pragma once
// Reliable delivery over any (best-effort) transport, independent of message schemas:
//  - ReliableSender keeps a bounded set of unacknowledged ids and calls send(id) again with exponential
//    backoff and jitter until acknowledge(id) or max_attempts; a worker thread sleeps on a condition
//    variable until the next deadline. The first retransmission waits one retransmission timeout (RTO),
//    adapted to the measured ack latency as in RFC 6298 (or a fixed initial_backoff with adaptive = false).
//  - DedupFilter on the receiver makes delivery idempotent on (sender, id) with bounded memory.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <random>
#include <set>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::transport {

struct ReliableSenderOptions {
  size_t max_pending = 256;  // submit() fails beyond this many unacknowledged ids
  /// true: the RTO follows the ack latency (RFC 6298: SRTT + max(G, 4 RTTVAR), Karn's rule, a backed-off
  /// RTO kept until the next valid sample); false: every id starts from initial_backoff.
  bool adaptive = true;
  std::chrono::milliseconds initial_backoff{100};  // RTO before the first ack sample (or always: !adaptive)
  std::chrono::milliseconds min_backoff{20};       // adaptive: the RTO never goes below this
  std::chrono::milliseconds max_backoff{2000};     // the RTO and each id's backoff stop growing here
  double backoff_factor = 2.0;                     // growth per retransmission
  double jitter = 0.2;    // each delay is scaled by 1 + U(-jitter, +jitter); adaptive: 1 + U(0, jitter)
  int max_attempts = 20;  // sends per id (first included) without an answer (progress() starts them
                          // again); then it is given up. 0: until acknowledged
  uint64_t seed = 1;      // jitter random stream
  /// adaptive: an id's backoff also raises the RTO new ids start from, until the next valid sample (RFC
  /// 6298 5.5, as for one connection); false: each id backs off on its own and the RTO follows the samples
  /// only (ids whose sends are lost independently and answered by progress(): a keyframe's chunk bursts).
  bool shared_backoff = true;
};

struct ReliableSenderStats {
  uint64_t submitted = 0;
  uint64_t retransmissions = 0;
  uint64_t acked = 0;
  uint64_t dropped_when_full = 0;  // submit() refused: max_pending reached
  uint64_t given_up = 0;           // max_attempts reached without an ack
  uint64_t send_failures = 0;      // send() returned an error (retried like a loss)
  uint64_t rtt_samples = 0;        // acks of ids sent exactly once (Karn's rule): the RTO's input
  double srtt_ms = 0.0;            // smoothed ack latency (0 before any sample)
  double rttvar_ms = 0.0;          // its mean deviation
  double rto_ms = 0.0;             // the timeout a newly submitted id gets now
};

/// RFC 6298 round-trip estimate; no sample yet while samples == 0.
struct RttEstimate {
  std::chrono::nanoseconds srtt{0};
  std::chrono::nanoseconds rttvar{0};
  uint64_t samples = 0;
};

class ReliableSender {
 public:
  using Clock = std::chrono::steady_clock;
  /// Called for the first transmission and every retransmission of `id`. With signed envelopes it must seal
  /// the message afresh each time (new seq): identical bytes are rejected by the receiver's replay guard.
  /// The receiver deduplicates by id (DedupFilter) and acknowledges duplicates again.
  using SendFn = std::function<Status(uint64_t id)>;
  /// Called (on the worker, without the sender's lock) for each id given up after max_attempts.
  using GiveUpFn = std::function<void(uint64_t id)>;

  ReliableSender(ReliableSenderOptions options, SendFn send, GiveUpFn given_up = {});
  ~ReliableSender();
  ReliableSender(const ReliableSender&) = delete;
  ReliableSender& operator=(const ReliableSender&) = delete;

  /// Starts the retransmission worker.
  void start();
  /// Wakes and joins the worker at once; pending ids stay pending. Idempotent.
  void stop();

  /// Sends `id` now (on the caller's thread) and schedules retransmissions. Fails if the queue is full
  /// or the id is already pending.
  Status submit(uint64_t id);
  /// Removes `id`; true if it was pending.
  bool acknowledge(uint64_t id);
  /// `id` made progress, answered after `round_trip` by something other than its ack (a ChunkAck for the
  /// chunks of a keyframe): an RTT sample (it ends a backoff, RFC 6298 5.7; Karn's rule leaves none on a
  /// link where every id needs more than one send), the id's next timeout restarts from the RTO and its
  /// max_attempts count starts again (an id is given up after max_attempts sends without any answer).
  /// Nothing for an id not pending.
  void progress(uint64_t id, std::chrono::nanoseconds round_trip);
  /// Every pending id is sent again at once (on the worker thread, counted as a retransmission), its
  /// timeout and max_attempts count starting again: none of its sends so far could have reached the
  /// peer that answers (that peer appeared only now: a DDS subscriber matched).
  void resendAllNow();
  size_t pending() const;
  ReliableSenderStats stats() const;

  /// Blocks until pending() < max_pending or `timeout`; true if there is room.
  bool waitForCapacity(std::chrono::milliseconds timeout);
  /// Blocks until nothing is pending or `timeout`; true if drained.
  bool waitUntilEmpty(std::chrono::milliseconds timeout);

  /// Clock granularity term G of RFC 6298 2.2-2.3 (also covers the worker's wake-up latency).
  static constexpr std::chrono::milliseconds kGranularity{10};
  /// RFC 6298 2.2-2.3: the estimate after ack latency `sample` (alpha 1/8, beta 1/4).
  static RttEstimate updateRtt(const RttEstimate& estimate, std::chrono::nanoseconds sample);
  /// RFC 6298 2.1-2.4: initial_backoff before any sample, else SRTT + max(G, 4 RTTVAR) clamped to
  /// [min_backoff, max_backoff] (max_backoff wins should they cross); never above max_backoff.
  static std::chrono::nanoseconds rto(const ReliableSenderOptions& options, const RttEstimate& estimate);
  /// An id's next (unjittered) timeout after one more unanswered send: its previous one times
  /// backoff_factor, at least `rto_now` (the sender's RTO now), at most max_backoff (RFC 6298 5.5).
  static std::chrono::nanoseconds backedOff(const ReliableSenderOptions& options,
                                            std::chrono::nanoseconds previous,
                                            std::chrono::nanoseconds rto_now);
  /// `delay` scaled by 1 + jitter * u for a draw u in [-1, 1].
  static std::chrono::nanoseconds jittered(const ReliableSenderOptions& options,
                                           std::chrono::nanoseconds delay, double u);

 private:
  struct Item {
    Clock::time_point first_sent;  // for the ack latency sample
    Clock::time_point deadline;
    std::chrono::nanoseconds delay{0};  // unjittered timeout of the latest send
    int attempts = 0;                   // sends (Karn's rule)
    int unanswered = 0;                 // sends since the id's last progress (max_attempts)
  };
  void run();
  void schedule(uint64_t id, Item& item, Clock::time_point now);  // caller holds mutex_
  void noteSample(std::chrono::nanoseconds sample);               // caller holds mutex_

  ReliableSenderOptions options_;
  SendFn send_;
  GiveUpFn given_up_;
  std::mutex lifecycle_;  ///< serialises start() and stop(), held across the join
  mutable std::mutex mutex_;
  std::condition_variable wake_;     // worker: new earliest deadline or stop
  std::condition_variable changed_;  // waiters: an id left the queue
  std::unordered_map<uint64_t, Item> items_;
  std::set<std::pair<Clock::time_point, uint64_t>> deadlines_;
  std::mt19937_64 rng_;
  RttEstimate rtt_;
  std::chrono::nanoseconds
      rto_;  ///< for new ids: rto(options_, rtt_), or backed off since (shared_backoff; RFC 6298 5.5-5.7)
  ReliableSenderStats stats_;
  bool stopping_ = false;
  std::thread worker_;
};

struct DedupOptions {
  size_t ids_per_sender = 4096;  // remembered ids per sender (oldest forgotten first)
  size_t max_senders = 256;      // remembered senders (least recently seen forgotten first)
};

/// accept(sender, id) is true the first time a pair is seen. Memory is bounded: an id older than
/// `ids_per_sender` accepted ids of its sender would be accepted again, so keep that window larger than
/// the sender's max_pending. Thread-safe.
class DedupFilter {
 public:
  explicit DedupFilter(DedupOptions options = {}) : options_(options) {}
  bool accept(uint64_t sender, uint64_t id);
  uint64_t duplicates() const;
  size_t remembered() const;

 private:
  struct Window {
    std::unordered_set<uint64_t> ids;
    std::deque<uint64_t> order;
    uint64_t last_seen = 0;
  };
  void evictSenderIfNeeded();  // caller holds mutex_

  DedupOptions options_;
  mutable std::mutex mutex_;
  std::unordered_map<uint64_t, Window> senders_;
  uint64_t tick_ = 0;
  uint64_t duplicates_ = 0;
};

}  // namespace rgbdmap::transport
