#pragma once
// Lock-free counters behind TransportStats.
#include <atomic>
#include <cstdint>

#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::transport {

struct StatsCounter {
  std::atomic<uint64_t> sent{0}, received{0}, send_errors{0}, bytes_sent{0}, bytes_received{0}, dropped{0};

  void onSent(size_t bytes) {
    sent.fetch_add(1, std::memory_order_relaxed);
    bytes_sent.fetch_add(bytes, std::memory_order_relaxed);
  }
  void onReceived(size_t bytes) {
    received.fetch_add(1, std::memory_order_relaxed);
    bytes_received.fetch_add(bytes, std::memory_order_relaxed);
  }
  TransportStats snapshot() const {
    TransportStats s;
    s.sent = sent.load();
    s.received = received.load();
    s.send_errors = send_errors.load();
    s.bytes_sent = bytes_sent.load();
    s.bytes_received = bytes_received.load();
    s.dropped = dropped.load();
    return s;
  }
};

}  // namespace rgbdmap::transport
