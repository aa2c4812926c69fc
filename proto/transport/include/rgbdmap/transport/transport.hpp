#pragma once
// One publish/subscribe interface for opaque byte messages. Adapters: LCM (memq://, udpm://) and
// Cyclone DDS (dds://). Message schemas live in proto/ and are serialised before they reach a Transport.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::transport {

/// Counters since construction. `dropped` counts messages the adapter received but could not deliver
/// (no matching handler, or DDS reports a lost sample). LCM udpm:// also receives the process's own
/// publications (multicast loopback): they count as received, and as dropped when nobody subscribed.
struct TransportStats {
  uint64_t sent = 0;
  uint64_t received = 0;
  uint64_t send_errors = 0;
  uint64_t bytes_sent = 0;
  uint64_t bytes_received = 0;
  uint64_t dropped = 0;
  /// Dropped on purpose by fault injection (drop= / drop_rx= in the URL; tests and benchmarks only).
  uint64_t fault_dropped_published = 0;
  uint64_t fault_dropped_received = 0;
};

/// publish() is thread-safe; handlers run on the transport's receive thread, one at a time, and may
/// call publish() and subscribe() themselves.
/// Subscribers matched with a writer (DDS publication-matched status).
struct SubscriberMatch {
  int current = 0;     ///< matched now
  uint64_t total = 0;  ///< ever matched: grows when a new subscriber (a restarted server) appears
};

class Transport {
 public:
  using Handler = std::function<void(const std::string& channel, const uint8_t* data, size_t size)>;
  virtual ~Transport() = default;

  virtual Status publish(const std::string& channel, const uint8_t* data, size_t size) = 0;
  /// Exact channel name, or a prefix ending in '*' ("rgbdmap/robot1/*"; on DDS the topics other
  /// participants publish, found as they appear).
  virtual Status subscribe(const std::string& channel, Handler handler) = 0;
  /// Starts the receive thread. Subscriptions may be added before or after.
  virtual Status start() = 0;
  /// Wakes and joins the receive thread promptly; idempotent. The destructor calls it.
  virtual void stop() = 0;
  virtual TransportStats stats() const = 0;
  /// The subscribers this process's writer of `channel` is matched with, on transports that match
  /// endpoints (DDS: a sample published while no subscriber is matched reaches nobody, not even one matched
  /// a moment later); nullopt where delivery does not depend on a match (LCM, memq). Creates the channel's
  /// writer if it has none yet, so that matching starts.
  /// True where the transport itself repairs lost datagrams between matched endpoints (DDS, reliable
  /// QoS): a resend on top of it only covers what it cannot repair.
  virtual bool repairsLoss() const { return false; }
  virtual std::optional<SubscriberMatch> matchedSubscribers(const std::string& channel) {
    (void)channel;
    return std::nullopt;
  }

  Status publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
    return publish(channel, bytes.data(), bytes.size());
  }
};

struct TransportOptions {
  /// memq:// (in-process LCM), udpm://group:port?ttl=..&recv_buf_size=.. (LCM), dds://?domain=N (Cyclone).
  /// Fault injection on any of them (tests, benchmarks): drop=P drops published messages, drop_rx=P
  /// received ones, each with probability P, seeded by drop_seed=N (default 1); logged as a warning.
  std::string url = "memq://";
  /// Channels whose last message reaches late joiners (DDS: TRANSIENT_LOCAL, keep-last 1), in addition
  /// to names ending in /map, /slice, /status, /pose_corrections, /hello or /loops. LCM has no durability:
  /// wrap an LCM transport in a LatestRepublisher (republisher.hpp) to give late joiners the latest message.
  std::vector<std::string> latest_for_late_joiners_channels;
  /// DDS keep-last depth for ordinary (volatile) channels.
  int dds_history_depth = 256;
  /// LCM per-subscription receive queue (messages); LCM's default of 30 drops bursts.
  int lcm_queue_capacity = 1024;
};

/// True if `channel` keeps its last message for late joiners under `options`.
bool isLatestForLateJoiners(const std::string& channel, const TransportOptions& options);

/// DDS topic name for a channel: letters and digits stay, '/' becomes "__", every other byte becomes
/// "_xHH" (hex), so the mapping is one-to-one; a leading digit is escaped too.
std::string ddsTopicName(const std::string& channel);
/// The channel of a DDS topic name (the inverse of ddsTopicName); false for a name ddsTopicName never makes.
bool channelFromDdsTopic(const std::string& topic, std::string* channel);

/// True if `channel` matches a subscription pattern (exact, or prefix when the pattern ends in '*').
bool channelMatches(const std::string& pattern, const std::string& channel);

/// What makeTransport checks before it creates anything (scheme, fault options, DDS domain, CYCLONEDDS_URI):
/// the programs call it with their configuration so that a transport that cannot be used is a
/// configuration error (exit 2), named at start.
Status checkTransportUrl(const std::string& url);

Result<std::unique_ptr<Transport>> makeTransport(const TransportOptions& options);
Result<std::unique_ptr<Transport>> makeTransport(const std::string& url);

}  // namespace rgbdmap::transport
