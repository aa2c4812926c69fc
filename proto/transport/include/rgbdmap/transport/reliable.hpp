#pragma once
// Reliable delivery over any (best-effort) transport, independent of message schemas:
//  - ReliableSender keeps a bounded set of unacknowledged ids and calls send(id) again with exponential
//    backoff and jitter until acknowledge(id) or max_attempts; a worker thread sleeps on a condition
//    variable until the next deadline.
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
  size_t max_pending = 256;                        // submit() fails beyond this many unacknowledged ids
  std::chrono::milliseconds initial_backoff{100};  // wait before the first retransmission
  std::chrono::milliseconds max_backoff{2000};     // backoff stops growing here
  double backoff_factor = 2.0;                     // growth per retransmission
  double jitter = 0.2;                             // each delay is scaled by 1 + U(-jitter, +jitter)
  int max_attempts = 20;                           // sends per id (first included); then it is given up
  uint64_t seed = 1;                               // jitter random stream
};

struct ReliableSenderStats {
  uint64_t submitted = 0;
  uint64_t retransmissions = 0;
  uint64_t acked = 0;
  uint64_t dropped_when_full = 0;  // submit() refused: max_pending reached
  uint64_t given_up = 0;           // max_attempts reached without an ack
  uint64_t send_failures = 0;      // send() returned an error (retried like a loss)
};

class ReliableSender {
 public:
  using Clock = std::chrono::steady_clock;
  /// Called for the first transmission and every retransmission of `id`. With signed envelopes it must seal
  /// the message afresh each time (new seq): identical bytes are rejected by the receiver's replay guard.
  /// The receiver deduplicates by id (DedupFilter) and acknowledges duplicates again.
  using SendFn = std::function<Status(uint64_t id)>;

  ReliableSender(ReliableSenderOptions options, SendFn send);
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
  size_t pending() const;
  ReliableSenderStats stats() const;

  /// Blocks until pending() < max_pending or `timeout`; true if there is room.
  bool waitForCapacity(std::chrono::milliseconds timeout);
  /// Blocks until nothing is pending or `timeout`; true if drained.
  bool waitUntilEmpty(std::chrono::milliseconds timeout);

  /// Delay after the `attempt`-th send (1-based) before the next one, for jitter draw u in [-1, 1].
  static std::chrono::nanoseconds backoff(const ReliableSenderOptions& options, int attempt, double u);

 private:
  struct Item {
    Clock::time_point deadline;
    int attempts = 0;
  };
  void run();
  Clock::time_point nextDeadline(int attempts, Clock::time_point now);  // caller holds mutex_
  void schedule(uint64_t id, Item& item, Clock::time_point now);        // caller holds mutex_

  ReliableSenderOptions options_;
  SendFn send_;
  std::mutex lifecycle_;  ///< serialises start() and stop(), held across the join
  mutable std::mutex mutex_;
  std::condition_variable wake_;     // worker: new earliest deadline or stop
  std::condition_variable changed_;  // waiters: an id left the queue
  std::unordered_map<uint64_t, Item> items_;
  std::set<std::pair<Clock::time_point, uint64_t>> deadlines_;
  std::mt19937_64 rng_;
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
