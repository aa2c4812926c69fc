// lcm_loss_probe: publishes N messages of S bytes on transport A and counts how many arrive on transport B
// (e.g. A = udpm://239.255.76.67:7667, B = udpm://239.255.76.68:7668 with rgbdmap-lossy-relay between them).
// Prints one line: "probe sent N received R bytes S fraction F". Test tool for deploy/bench_lcm_loss.sh.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "rgbdmap/transport/transport.hpp"

int main(int argc, char** argv) {
  if (argc < 6) {
    std::fprintf(stderr, "usage: lcm_loss_probe URL_A URL_B COUNT BYTES INTERVAL_MS\n");
    return 2;
  }
  const int count = std::atoi(argv[3]);
  const size_t bytes = static_cast<size_t>(std::atol(argv[4]));
  const int interval_ms = std::atoi(argv[5]);
  if (count <= 0 || count > 100000 || bytes < 8 || bytes > (64u << 20) || interval_ms < 0) return 2;
  auto a = rgbdmap::transport::makeTransport(std::string(argv[1]));
  auto b = rgbdmap::transport::makeTransport(std::string(argv[2]));
  if (!a || !b) {
    std::fprintf(stderr, "cannot open transports\n");
    return 1;
  }
  std::vector<std::atomic<bool>> seen(static_cast<size_t>(count));
  std::atomic<int> received{0};
  (*b)->subscribe("probe/data", [&](const std::string&, const uint8_t* data, size_t size) {
    if (size != bytes) return;
    uint32_t id = 0;
    std::memcpy(&id, data, sizeof(id));
    if (id < static_cast<uint32_t>(count) && !seen[id].exchange(true)) ++received;
  });
  (*a)->start();
  (*b)->start();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<uint8_t> payload(bytes);
  for (size_t i = 0; i < bytes; ++i) payload[i] = static_cast<uint8_t>(i * 131u);
  for (int i = 0; i < count; ++i) {
    const uint32_t id = static_cast<uint32_t>(i);
    std::memcpy(payload.data(), &id, sizeof(id));
    (*a)->publish("probe/data", payload.data(), payload.size());
    std::this_thread::sleep_for(std::chrono::milliseconds(interval_ms));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  (*a)->stop();
  (*b)->stop();
  std::printf("probe sent %d received %d bytes %zu fraction %.3f\n", count, received.load(), bytes,
              static_cast<double>(received.load()) / count);
  return 0;
}
