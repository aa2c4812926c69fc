// bench_transport: keyframes (110 KB) per second, MB/s and small-message round-trip latency.
// memq:// runs in-process; udpm:// and dds:// run against a peer process (this binary with --peer URL) so
// the bytes cross the loopback network, and only inside a network namespace (deploy/bench_transport.sh).
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "rgbdmap/transport/transport.hpp"

extern char** environ;

namespace {

using namespace rgbdmap::transport;
using Clock = std::chrono::steady_clock;

constexpr size_t kKeyframeBytes = 110 * 1024;
const char* kUdpmUrl = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608";

/// Counts replies (acks, pongs) and lets the driver wait on them.
struct Replies {
  std::mutex mutex;
  std::condition_variable cv;
  uint64_t acks = 0, pongs = 0, last_pong = 0;
  void ack() {
    std::lock_guard<std::mutex> lock(mutex);
    ++acks;
    cv.notify_all();
  }
  void pong(uint64_t seq) {
    std::lock_guard<std::mutex> lock(mutex);
    ++pongs;
    last_pong = seq;
    cv.notify_all();
  }
};

/// The echo side: keyframe -> 8-byte ack, ping -> pong with the same bytes.
void attachEcho(Transport& t) {
  t.subscribe("bench/keyframe",
              [&t](const std::string&, const uint8_t* d, size_t) { t.publish("bench/ack", d, 8); });
  t.subscribe("bench/ping",
              [&t](const std::string&, const uint8_t* d, size_t n) { t.publish("bench/pong", d, n); });
}

uint64_t seqOf(const uint8_t* d) {
  uint64_t v = 0;
  std::memcpy(&v, d, 8);
  return v;
}

bool ping(Transport& t, Replies& r, uint64_t seq, std::chrono::milliseconds timeout) {
  std::vector<uint8_t> msg(64, 0);
  std::memcpy(msg.data(), &seq, 8);
  t.publish("bench/ping", msg);
  std::unique_lock<std::mutex> lock(r.mutex);
  return r.cv.wait_for(lock, timeout, [&] { return r.last_pong == seq; });
}

void measureLatency(Transport& t, Replies& r, int count) {
  std::vector<double> rtt_us;
  int lost = 0;
  for (int i = 0; i < count; ++i) {
    const auto t0 = Clock::now();
    if (!ping(t, r, 1000000 + static_cast<uint64_t>(i), std::chrono::milliseconds(500))) {
      ++lost;
      continue;
    }
    rtt_us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
  }
  if (rtt_us.empty()) return void(std::printf("  latency: no replies\n"));
  std::sort(rtt_us.begin(), rtt_us.end());
  const auto at = [&](double q) { return rtt_us[static_cast<size_t>(q * (rtt_us.size() - 1))]; };
  std::printf("  64 B round trip (us): median %.0f  p99 %.0f  max %.0f  (%zu samples, %d lost)\n", at(0.5),
              at(0.99), rtt_us.back(), rtt_us.size(), lost);
}

void measureThroughput(Transport& t, Replies& r, int count, int window) {
  std::vector<uint8_t> keyframe(kKeyframeBytes, 0x5A);
  uint64_t base = 0;
  {
    std::lock_guard<std::mutex> lock(r.mutex);
    base = r.acks;
  }
  int stalls = 0;
  const auto t0 = Clock::now();
  for (int i = 0; i < count; ++i) {
    std::unique_lock<std::mutex> lock(r.mutex);
    // Keep at most `window` keyframes in flight; a lost one (udpm) ends the wait after 200 ms.
    if (!r.cv.wait_for(lock, std::chrono::milliseconds(200), [&] {
          return static_cast<int64_t>(i) - static_cast<int64_t>(r.acks - base) < window;
        })) {
      ++stalls;
      base -= 1;  // treat one in-flight keyframe as lost
    }
    lock.unlock();
    const uint64_t seq = static_cast<uint64_t>(i);
    std::memcpy(keyframe.data(), &seq, 8);
    t.publish("bench/keyframe", keyframe);
  }
  std::unique_lock<std::mutex> lock(r.mutex);
  r.cv.wait_for(lock, std::chrono::seconds(2), [&] { return r.acks - base >= static_cast<uint64_t>(count); });
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  const double delivered =
      static_cast<double>(std::min<uint64_t>(r.acks - base, static_cast<uint64_t>(count)));
  std::printf("  110 KB keyframes: %.0f /s, %.1f MB/s (%d sent, window %d, %d stalls on loss, %.2f s)\n",
              delivered / seconds, delivered * kKeyframeBytes / seconds / 1e6, count, window, stalls,
              seconds);
}

pid_t spawnPeer(const char* self, const std::string& url) {
  std::string a0 = self, a1 = "--peer", a2 = url;
  char* argv[] = {a0.data(), a1.data(), a2.data(), nullptr};
  pid_t pid = -1;
  return posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv, environ) == 0 ? pid : -1;
}

/// Peer process: echo until "bench/quit" or 120 s.
int runPeer(const std::string& url) {
  auto t = makeTransport(url);
  if (!t) return std::fprintf(stderr, "peer: %s\n", t.error().c_str()), 1;
  std::mutex m;
  std::condition_variable cv;
  bool quit = false;
  attachEcho(**t);
  (*t)->subscribe("bench/quit", [&](const std::string&, const uint8_t*, size_t) {
    std::lock_guard<std::mutex> lock(m);
    quit = true;
    cv.notify_all();
  });
  (*t)->start();
  std::unique_lock<std::mutex> lock(m);
  cv.wait_for(lock, std::chrono::seconds(120), [&] { return quit; });
  return 0;
}

bool allowedOnNetwork(const std::string& name) {
  const char* netns = std::getenv("RGBDMAP_TRANSPORT_NETNS");
  const bool in_netns = netns != nullptr && std::string(netns) == "1";
  const char* uri = std::getenv("CYCLONEDDS_URI");
  const bool loopback_dds = uri != nullptr && std::strstr(uri, "cyclonedds-loopback.xml") != nullptr;
  if (name == "dds" && in_netns && !loopback_dds) {
    const std::string cfg =
        std::string("file://") + RGBDMAP_SOURCE_DIR + "/deploy/dds/cyclonedds-loopback.xml";
    setenv("CYCLONEDDS_URI", cfg.c_str(), 1);
  }
  if (in_netns || (name == "dds" && loopback_dds)) return true;
  std::printf(
      "%s: refusing to run outside a private network namespace. Run:\n"
      "  bash deploy/bench_transport.sh   (wraps this program in unshare -n, loopback only)\n",
      name.c_str());
  return false;
}

void runOne(const char* self, const std::string& name, int keyframes) {
  const std::string url = name == "memq" ? "memq://" : name == "udpm" ? kUdpmUrl : "dds://?domain=0";
  if (name != "memq" && !allowedOnNetwork(name)) return;
  auto made = makeTransport(url);
  if (!made) return void(std::printf("%s: %s\n", name.c_str(), made.error().c_str()));
  Transport& t = **made;
  Replies r;
  t.subscribe("bench/ack", [&r](const std::string&, const uint8_t*, size_t) { r.ack(); });
  t.subscribe("bench/pong", [&r](const std::string&, const uint8_t* d, size_t) { r.pong(seqOf(d)); });
  pid_t peer = -1;
  if (name == "memq")
    attachEcho(t);  // in-process: the echo runs on the same receive thread
  else
    peer = spawnPeer(self, url);
  t.start();
  int probes = 0;
  while (probes < 100 && !ping(t, r, 1 + static_cast<uint64_t>(probes), std::chrono::milliseconds(100)))
    ++probes;
  std::printf("%s (%s)%s\n", name.c_str(), url.c_str(), peer > 0 ? ", peer process" : ", in-process");
  if (probes < 100) {
    measureLatency(t, r, 2000);
    measureThroughput(t, r, keyframes, 16);
  } else {
    std::printf("  peer did not answer\n");
  }
  if (peer > 0) {
    for (int i = 0; i < 5; ++i) t.publish("bench/quit", std::vector<uint8_t>{1});
    int status = 0;
    waitpid(peer, &status, 0);
  }
  t.stop();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::string(argv[1]) == "--peer") return runPeer(argv[2]);
  std::vector<std::string> names = {"memq", "udpm", "dds"};
  int keyframes = 1000;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--only") names = {argv[i + 1]};
    if (std::string(argv[i]) == "--keyframes") keyframes = std::max(1, std::atoi(argv[i + 1]));
  }
  for (const auto& name : names) runOne(argv[0], name, keyframes);
  return 0;
}
