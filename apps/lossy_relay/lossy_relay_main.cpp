// rgbdmap-lossy-relay: a test tool that forwards UDP datagrams between two LCM multicast endpoints (e.g. the
// robots on udpm://239.255.76.67:7667 and the server on udpm://239.255.76.68:7668) and drops some of them,
// for loss experiments on machines without netem. Run it only inside tests/transport/run_in_netns.sh.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/transport/lcm_datagram.hpp"

namespace rgbdmap::relay {
namespace {

const char* kUsage =
    "usage: rgbdmap-lossy-relay --a udpm://GROUP:PORT --b udpm://GROUP:PORT [options]\n"
    "Forwards every datagram of LCM endpoint A to B and of B to A, dropping some on the way.\n"
    "A and B must use different ports (each side's LCM binds its port on every address).\n"
    "  --drop-datagrams P  drop each datagram with probability P (default 0)\n"
    "  --mtu M             with --drop-datagrams: P is the loss of each IP packet on a link of MTU M; a\n"
    "                      datagram larger than one packet is lost when any of its IP fragments is\n"
    "                      (LCM sends up to ~64 KB per datagram; loopback has no IP fragmentation)\n"
    "  --drop-messages P   drop each LCM message (all its fragments) with probability P (default 0)\n"
    "  --seed N            random seed (default 1)\n"
    "  --duration S        exit after S seconds (default 0: until SIGINT/SIGTERM)\n"
    "  --stats FILE        write the counters as JSON to FILE at exit\n"
    "Prints the counters (forwarded, dropped, per direction) at exit.\n";

std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop = true; }

struct Endpoint {
  sockaddr_in group{};
  int rx = -1;
};

struct Counters {
  uint64_t received = 0, forwarded = 0, dropped = 0, own_ignored = 0, not_lcm = 0;
  uint64_t messages = 0, messages_dropped = 0;  ///< LCM messages seen (first fragments) / chosen for dropping
};

/// "udpm://239.255.76.67:7667?ttl=0" -> group and port.
bool parseUdpmUrl(const std::string& url, sockaddr_in* out) {
  const std::string prefix = "udpm://";
  if (url.compare(0, prefix.size(), prefix) != 0) return false;
  const std::string rest = url.substr(prefix.size(), url.find('?') - prefix.size());
  const size_t colon = rest.find(':');
  if (colon == std::string::npos) return false;
  *out = sockaddr_in{};
  out->sin_family = AF_INET;
  if (inet_pton(AF_INET, rest.substr(0, colon).c_str(), &out->sin_addr) != 1) return false;
  if (!IN_MULTICAST(ntohl(out->sin_addr.s_addr))) return false;
  const long port = std::strtol(rest.c_str() + colon + 1, nullptr, 10);
  if (port <= 0 || port > 65535) return false;
  out->sin_port = htons(static_cast<uint16_t>(port));
  return true;
}

/// A socket bound to the group's port on every address and joined to the group, as LCM's own receiver.
int openReceiver(const sockaddr_in& group) {
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  const int one = 1, rcvbuf = 8 << 20;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
  sockaddr_in bind_addr{};
  bind_addr.sin_family = AF_INET;
  bind_addr.sin_addr.s_addr = htonl(INADDR_ANY);
  bind_addr.sin_port = group.sin_port;
  ip_mreq mreq{};
  mreq.imr_multiaddr = group.sin_addr;
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  if (bind(fd, reinterpret_cast<sockaddr*>(&bind_addr), sizeof(bind_addr)) != 0 ||
      setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof(mreq)) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

/// The sending socket (TTL 0, loopback on); its port identifies the relay's own datagrams.
int openSender(uint16_t* port) {
  const int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  const unsigned char ttl = 0, loop = 1;
  setsockopt(fd, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof(ttl));
  setsockopt(fd, IPPROTO_IP, IP_MULTICAST_LOOP, &loop, sizeof(loop));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  socklen_t len = sizeof(addr);
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    close(fd);
    return -1;
  }
  *port = ntohs(addr.sin_port);
  return fd;
}

struct Relay {
  Endpoint a, b;
  int tx = -1;
  uint16_t tx_port = 0;
  double drop_datagrams = 0.0, drop_messages = 0.0;
  int mtu = 0;  ///< 0: --drop-datagrams applies per datagram
  uint64_t seed = 1;
  std::mt19937_64 rng;
  Counters a_to_b, b_to_a;

  bool shouldDrop(const uint8_t* data, size_t size, const sockaddr_in& from, Counters* c) {
    LcmDatagramHeader h;
    const bool lcm = parseLcmDatagram(data, size, &h);
    if (!lcm) ++c->not_lcm;
    if (lcm && h.fragment_no == 0) ++c->messages;
    if (lcm && drop_messages > 0.0 &&
        dropMessage(seed, ntohl(from.sin_addr.s_addr), ntohs(from.sin_port), h.sequence, drop_messages)) {
      if (h.fragment_no == 0) ++c->messages_dropped;
      return true;
    }
    return drop_datagrams > 0.0 &&
           std::uniform_real_distribution<double>(0.0, 1.0)(rng) < datagramLoss(drop_datagrams, size, mtu);
  }

  /// Reads one datagram from `from_fd` and forwards it to `to` unless it is the relay's own or dropped.
  void pump(int from_fd, const sockaddr_in& to, Counters* c) {
    static uint8_t buffer[65536];
    sockaddr_in from{};
    socklen_t from_len = sizeof(from);
    const ssize_t n = recvfrom(from_fd, buffer, sizeof(buffer), MSG_DONTWAIT,
                               reinterpret_cast<sockaddr*>(&from), &from_len);
    if (n < 0) return;
    // Same host (loopback in a namespace): the sending socket's port identifies the relay's own datagrams.
    if (ntohs(from.sin_port) == tx_port) {
      ++c->own_ignored;
      return;
    }
    ++c->received;
    if (shouldDrop(buffer, static_cast<size_t>(n), from, c)) {
      ++c->dropped;
      return;
    }
    if (sendto(tx, buffer, static_cast<size_t>(n), 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) ==
        n) {
      ++c->forwarded;
    }
  }

  void run(double duration_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(duration_s);
    pollfd fds[2] = {{a.rx, POLLIN, 0}, {b.rx, POLLIN, 0}};
    while (!g_stop) {
      if (duration_s > 0.0 && std::chrono::steady_clock::now() >= end) break;
      fds[0].revents = fds[1].revents = 0;
      if (poll(fds, 2, 100) <= 0) continue;
      if (fds[0].revents & POLLIN) pump(a.rx, b.group, &a_to_b);
      if (fds[1].revents & POLLIN) pump(b.rx, a.group, &b_to_a);
    }
  }
};

std::string countersJson(const Counters& c) {
  char text[320];
  std::snprintf(text, sizeof(text),
                "{\"received\": %llu, \"forwarded\": %llu, \"dropped\": %llu, \"own_ignored\": %llu, "
                "\"not_lcm\": %llu, \"messages\": %llu, \"messages_dropped\": %llu}",
                static_cast<unsigned long long>(c.received), static_cast<unsigned long long>(c.forwarded),
                static_cast<unsigned long long>(c.dropped), static_cast<unsigned long long>(c.own_ignored),
                static_cast<unsigned long long>(c.not_lcm), static_cast<unsigned long long>(c.messages),
                static_cast<unsigned long long>(c.messages_dropped));
  return text;
}

int report(const Relay& relay, const std::string& stats_file) {
  std::printf("lossy-relay a->b %s\nlossy-relay b->a %s\n", countersJson(relay.a_to_b).c_str(),
              countersJson(relay.b_to_a).c_str());
  std::fflush(stdout);
  if (stats_file.empty()) return 0;
  const std::string json =
      "{\"a_to_b\": " + countersJson(relay.a_to_b) + ", \"b_to_a\": " + countersJson(relay.b_to_a) + "}\n";
  const Status written = writeTextFileAtomic(stats_file, json);
  if (!written.ok())
    std::fprintf(stderr, "cannot write %s: %s\n", stats_file.c_str(), written.error().c_str());
  return written.ok() ? 0 : 1;
}

int relayMain(int argc, char** argv) {
  cli::Args args(argc, argv, {"help"});
  if (args.has("help")) {
    std::printf("%s", kUsage);
    return 0;
  }
  args.checkAllowed(
      {"a", "b", "drop-datagrams", "mtu", "drop-messages", "seed", "duration", "stats", "help"});
  Relay relay;
  if (!parseUdpmUrl(args.getOr("a", ""), &relay.a.group)) args.addError("--a needs udpm://GROUP:PORT");
  if (!parseUdpmUrl(args.getOr("b", ""), &relay.b.group)) args.addError("--b needs udpm://GROUP:PORT");
  if (args.errors().empty() && relay.a.group.sin_port == relay.b.group.sin_port)
    args.addError("--a and --b need different ports");
  relay.drop_datagrams = args.getDouble("drop-datagrams").value_or(0.0);
  relay.drop_messages = args.getDouble("drop-messages").value_or(0.0);
  relay.seed = static_cast<uint64_t>(args.getInt("seed").value_or(1));
  const double duration_s = args.getDouble("duration").value_or(0.0);
  relay.mtu = static_cast<int>(args.getInt("mtu").value_or(0));
  if (relay.mtu != 0 && (relay.mtu < 576 || relay.mtu > 65535))
    args.addError("--mtu must be 0 or 576..65535");
  if (relay.drop_datagrams < 0 || relay.drop_datagrams > 1 || relay.drop_messages < 0 ||
      relay.drop_messages > 1)
    args.addError("drop probabilities must be in [0, 1]");
  if (duration_s < 0) args.addError("--duration must be >= 0");
  if (!args.errors().empty()) return cli::usageError(args.errors(), kUsage);
  relay.rng.seed(relay.seed);
  relay.a.rx = openReceiver(relay.a.group);
  relay.b.rx = openReceiver(relay.b.group);
  relay.tx = openSender(&relay.tx_port);
  if (relay.a.rx < 0 || relay.b.rx < 0 || relay.tx < 0) {
    std::perror("rgbdmap-lossy-relay: socket setup");
    return 1;
  }
  signal(SIGINT, onSignal);
  signal(SIGTERM, onSignal);
  std::printf("lossy-relay ready (sender port %u)\n", relay.tx_port);
  std::fflush(stdout);
  relay.run(duration_s);
  close(relay.a.rx);
  close(relay.b.rx);
  close(relay.tx);
  return report(relay, args.getOr("stats", ""));
}

}  // namespace
}  // namespace rgbdmap::relay

int main(int argc, char** argv) { return rgbdmap::relay::relayMain(argc, argv); }
