#pragma once
// Cyclone DDS adapter (dds://?domain=N). One topic per channel (created lazily), reliable QoS; channels
// that keep their latest message for late joiners are TRANSIENT_LOCAL. A waitset thread takes samples;
// a guard condition wakes it for stop(). A prefix subscription ("rgbdmap/*") reads the built-in
// DCPSPublication topic: each rgbdmap envelope topic another participant publishes whose channel matches
// gets a reader (at most kMaxDiscoveredReaders, so invented topic names cannot grow it without bound); the
// messages a writer sent before its reader matched are not received.
#include <dds/dds.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "handler_table.hpp"
#include "rgbdmap/transport/transport.hpp"
#include "stats_counter.hpp"

namespace rgbdmap::transport {

class DdsTransport final : public Transport {
 public:
  static Result<std::unique_ptr<Transport>> create(const TransportOptions& options, int domain_id);
  ~DdsTransport() override;

  Status publish(const std::string& channel, const uint8_t* data, size_t size) override;
  Status subscribe(const std::string& channel, Handler handler) override;
  Status start() override;
  void stop() override;
  TransportStats stats() const override { return stats_.snapshot(); }
  std::optional<SubscriberMatch> matchedSubscribers(const std::string& channel) override;
  bool repairsLoss() const override { return true; }

 private:
  DdsTransport(TransportOptions options, dds_entity_t participant, dds_entity_t waitset, dds_entity_t guard)
      : options_(std::move(options)), participant_(participant), waitset_(waitset), guard_(guard) {}
  Result<dds_entity_t> topicFor(const std::string& channel);  // caller holds entities_mutex_
  Result<dds_entity_t> writerFor(const std::string& channel);
  dds_qos_t* qosFor(const std::string& channel, bool writer) const;
  void receiveLoop();
  void drain(dds_entity_t reader);
  Status createReader(const std::string& channel);  // caller holds entities_mutex_
  Status watchPublications();                       // caller holds entities_mutex_
  void discover();  ///< new publications: readers for the channels a prefix subscription matches

  TransportOptions options_;
  dds_entity_t participant_;
  dds_entity_t waitset_;
  dds_entity_t guard_;
  std::mutex entities_mutex_;
  std::map<std::string, dds_entity_t> topics_, writers_, readers_;
  std::map<dds_entity_t, std::string> reader_channels_;
  static constexpr size_t kMaxDiscoveredReaders = 4096;
  std::vector<std::string> prefixes_;  ///< prefix subscriptions ("rgbdmap/*")
  /// Reader of DCPSPublication, once a prefix is subscribed (read by the receive thread without the lock).
  std::atomic<dds_entity_t> publications_{0};
  size_t discovered_readers_ = 0;
  std::thread thread_;
  std::mutex lifecycle_mutex_;
  std::atomic<bool> stopping_{false};
  HandlerTable handlers_;
  StatsCounter stats_;
};

}  // namespace rgbdmap::transport
