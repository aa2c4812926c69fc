#pragma once
// Fault injection for tests and benchmarks: a Transport decorator that drops whole messages, published and
// received, each with a seeded probability. Enabled by query parameters on any transport URL (see
// parseFaultOptions); makeTransport strips them before the inner adapter sees the URL and logs a loud
// warning that messages are being dropped on purpose.
#include <atomic>
#include <memory>
#include <mutex>
#include <random>
#include <string>

#include "rgbdmap/transport/transport.hpp"
#include "stats_counter.hpp"

namespace rgbdmap::transport {

struct FaultOptions {
  double drop_publish = 0.0;  ///< probability that publish() drops a message (reports success)
  double drop_receive = 0.0;  ///< probability that a received message is not handed to a handler (each
                              ///< subscription decides on its own)
  uint64_t seed = 0;          ///< of the drop decisions (one generator per transport)
  bool enabled() const { return drop_publish > 0.0 || drop_receive > 0.0; }
};

/// Reads and removes the fault parameters from `*url`: drop=P (published messages), drop_rx=P (received
/// messages), drop_seed=N (default 1). P in [0, 1). Returns the error text for a malformed value, else "".
std::string parseFaultOptions(std::string* url, FaultOptions* out);

class FaultInjectingTransport final : public Transport {
 public:
  FaultInjectingTransport(std::unique_ptr<Transport> inner, const FaultOptions& options);
  ~FaultInjectingTransport() override { inner_->stop(); }  ///< no handler runs once members go

  Status publish(const std::string& channel, const uint8_t* data, size_t size) override;
  Status subscribe(const std::string& channel, Handler handler) override;
  Status start() override { return inner_->start(); }
  void stop() override { inner_->stop(); }
  TransportStats stats() const override;
  bool repairsLoss() const override { return inner_->repairsLoss(); }
  std::optional<SubscriberMatch> matchedSubscribers(const std::string& channel) override {
    return inner_->matchedSubscribers(channel);
  }

 private:
  bool drop(double probability);

  std::unique_ptr<Transport> inner_;
  const FaultOptions options_;
  std::mutex rng_mutex_;
  std::mt19937_64 rng_;
  std::atomic<uint64_t> dropped_published_{0}, dropped_received_{0};
};

}  // namespace rgbdmap::transport
