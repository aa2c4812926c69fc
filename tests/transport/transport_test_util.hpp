#pragma once
// Helpers for the transport tests: a message inbox with a condition variable, payloads, netns gating.
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::transport::testing {

/// LCM multicast on loopback: TTL 0 keeps it on the host; the receive buffer holds bursts of keyframes.
inline const char* kUdpmUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608";

/// True when run by tests/transport/run_in_netns.sh (private network namespace, loopback only).
inline bool inNetns() {
  const char* v = std::getenv("RGBDMAP_TRANSPORT_NETNS");
  return v != nullptr && std::string(v) == "1";
}

/// Points Cyclone DDS at the loopback-only configuration before any participant exists.
inline void useLoopbackDdsConfig() {
  const std::string uri = std::string("file://") + RGBDMAP_SOURCE_DIR + "/deploy/dds/cyclonedds-loopback.xml";
  setenv("CYCLONEDDS_URI", uri.c_str(), 1);
}

/// A transport for URL (DDS on the loopback configuration); fails the test and returns null when it cannot.
inline std::unique_ptr<Transport> makeTestTransport(const std::string& url) {
  if (url.rfind("dds", 0) == 0) useLoopbackDdsConfig();
  auto t = makeTransport(url);
  EXPECT_TRUE(t.ok()) << t.error();
  return t.ok() ? std::move(t).value() : nullptr;
}

#define RGBDMAP_REQUIRE_NETNS()                                                                \
  do {                                                                                         \
    if (!::rgbdmap::transport::testing::inNetns())                                             \
      GTEST_SKIP() << "network test: runs only inside tests/transport/run_in_netns.sh (ctest " \
                      "entry transport.netns)";                                                \
  } while (0)

inline std::vector<uint8_t> makePayload(size_t size, uint32_t seed) {
  std::vector<uint8_t> out(size);
  uint32_t x = seed * 2654435761u + 1u;
  for (auto& b : out) {
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    b = static_cast<uint8_t>(x);
  }
  return out;
}

struct Inbox {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> messages;

  Transport::Handler handler() {
    return [this](const std::string& channel, const uint8_t* data, size_t size) {
      std::lock_guard<std::mutex> lock(mutex);
      messages.emplace_back(channel, std::vector<uint8_t>(data, data + size));
      cv.notify_all();
    };
  }
  bool waitFor(size_t count, std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex);
    return cv.wait_for(lock, timeout, [&] { return messages.size() >= count; });
  }
  /// Messages longer than `min_size` bytes (skips 1-byte connection probes).
  std::vector<std::vector<uint8_t>> payloadsLongerThan(size_t min_size) {
    std::lock_guard<std::mutex> lock(mutex);
    std::vector<std::vector<uint8_t>> out;
    for (const auto& m : messages) {
      if (m.second.size() > min_size) out.push_back(m.second);
    }
    return out;
  }
  bool waitForLongerThan(size_t count, size_t min_size, std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex);
    return cv.wait_for(lock, timeout, [&] {
      size_t n = 0;
      for (const auto& m : messages) n += m.second.size() > min_size ? 1 : 0;
      return n >= count;
    });
  }
  size_t size() {
    std::lock_guard<std::mutex> lock(mutex);
    return messages.size();
  }
};

/// Publishes a probe until the subscriber sees one (bounded), so later messages are not lost to discovery.
inline bool waitUntilConnected(Transport& tx, Inbox& probe_inbox, const std::string& channel) {
  const uint8_t probe = 1;
  for (int i = 0; i < 100; ++i) {
    if (!tx.publish(channel, &probe, 1)) return false;
    if (probe_inbox.waitFor(1, std::chrono::milliseconds(50))) return true;
  }
  return false;
}

inline double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace rgbdmap::transport::testing
