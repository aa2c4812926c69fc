#pragma once
// Late joiners over LCM: LCM keeps nothing, so the latest message of each "latest for late joiners"
// channel (isLatestForLateJoiners) is re-published periodically. On DDS, TRANSIENT_LOCAL does this already.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::transport {

struct RepublisherOptions {
  std::chrono::milliseconds period{1000};  ///< how often each latest message is sent again
  TransportOptions channels;               ///< which channels count as latest-for-late-joiners
  /// If set, called at each re-publish with the channel and the bytes last published there; returns the
  /// bytes to send now, e.g. the same message sealed afresh with a new seq so that receivers' replay
  /// protection accepts it (unchanged bytes would be refused as a replay). An empty result skips it.
  std::function<std::vector<uint8_t>(const std::string& channel, const std::vector<uint8_t>& last)> refresh;
};

/// Publishes through `transport` and remembers the latest payload of every late-joiner channel; a worker
/// thread re-sends them every period (waiting on a condition variable, so stop() returns at once).
/// Thread-safe. The transport must outlive the republisher.
class LatestRepublisher {
 public:
  LatestRepublisher(Transport& transport, RepublisherOptions options = {});
  ~LatestRepublisher();
  LatestRepublisher(const LatestRepublisher&) = delete;
  LatestRepublisher& operator=(const LatestRepublisher&) = delete;

  Status publish(const std::string& channel, const std::vector<uint8_t>& bytes);
  void start();
  void stop();
  uint64_t republished() const;

 private:
  void run();

  Transport& transport_;
  RepublisherOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::map<std::string, std::vector<uint8_t>> latest_;
  std::mutex lifecycle_;  ///< serialises start() and stop() (held across the join)
  std::thread worker_;
  bool running_ = false;
  uint64_t republished_ = 0;
};

}  // namespace rgbdmap::transport
