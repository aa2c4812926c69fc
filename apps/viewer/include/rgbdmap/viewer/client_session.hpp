#pragma once
// One WebSocket client of the viewer: its subscriptions (subscription id -> channel id), a bounded outgoing
// queue and the thread that writes it to the socket. A client that reads slowly (or not at all) only fills
// its own queue: once it holds max_queue_bytes or max_queue_messages, further messages to it are dropped
// and counted; a dropped latest-state message is resent once the queue has drained, a dropped incremental
// one makes the client wait for a full snapshot. The transport and the other clients never wait for it.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>

namespace rgbdmap::viewer {

struct SessionLimits {
  size_t max_queue_bytes = 32u << 20;
  size_t max_queue_messages = 1024;
  size_t max_subscriptions = 256;
};

struct SessionCounters {
  uint64_t messages_sent = 0, bytes_sent = 0;
  uint64_t dropped_messages = 0, dropped_bytes = 0;
  uint64_t write_errors = 0;
};

class ClientSession {
 public:
  /// Writes one WebSocket frame (text or binary); false when the connection failed.
  using Writer = std::function<bool(bool binary, const std::string& bytes)>;
  /// Called on the session's thread when the queue has drained and `channel`'s latest message was dropped.
  using Resend = std::function<void(ClientSession&, uint32_t channel)>;

  ClientSession(uint64_t id, SessionLimits limits, Writer writer, Resend resend);
  ~ClientSession();  ///< close()
  ClientSession(const ClientSession&) = delete;
  ClientSession& operator=(const ClientSession&) = delete;

  void start();
  /// Stops the writer thread (after the frame it is writing) and discards the queue; idempotent.
  void close();
  uint64_t id() const { return id_; }

  /// Queues a text frame (protocol messages); false when dropped.
  bool sendText(std::string text);
  /// Queues a messageData frame for `channel` if the client subscribed to it (else false). `incremental`:
  /// the message depends on the previous ones on that channel (not sent while a snapshot is awaited).
  bool sendMessage(uint32_t channel, const std::shared_ptr<const std::string>& payload, uint64_t time_ns,
                   bool incremental);
  /// Queues a snapshot for `channel` when the client subscribed and (unless `everyone`) awaits one.
  bool sendSnapshot(uint32_t channel, const std::shared_ptr<const std::string>& payload, uint64_t time_ns,
                    bool everyone);

  /// "" on success, else why not (duplicate subscription id, too many subscriptions, ...).
  std::string subscribe(uint32_t subscription_id, uint32_t channel);
  bool unsubscribe(uint32_t subscription_id);
  bool subscribed(uint32_t channel) const;
  /// The next message on `channel` must be a snapshot (its incremental messages are held back until then).
  void awaitSnapshot(uint32_t channel);
  bool awaitsSnapshot(uint32_t channel) const;
  SessionCounters counters() const;

 private:
  struct Frame {
    bool binary = false;
    std::string text;                            ///< text frames
    uint32_t subscription = 0, channel = 0;      ///< binary messageData frames
    std::shared_ptr<const std::string> payload;  ///< shared with the other clients
    uint64_t time_ns = 0;
    size_t size() const { return binary ? 13 + payload->size() : text.size(); }
  };
  bool pushLocked(Frame frame, bool incremental);
  void run();

  const uint64_t id_;
  const SessionLimits limits_;
  Writer writer_;
  Resend resend_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Frame> queue_;
  size_t queued_bytes_ = 0;
  std::map<uint32_t, uint32_t> channel_of_;       ///< subscription id -> channel
  std::map<uint32_t, uint32_t> subscription_of_;  ///< channel -> subscription id
  std::set<uint32_t> awaiting_snapshot_, stale_;  ///< channels
  SessionCounters counters_;
  bool closed_ = false, failed_ = false;
  std::thread thread_;
};

}  // namespace rgbdmap::viewer
