// udpm:// and dds:// between two processes (this test binary re-run as an echo peer), so messages cross the
// loopback network instead of Cyclone's in-process shortcut; plus a DDS late joiner in another process.
// Run only inside tests/transport/run_in_netns.sh.
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>

#include "test_tier.hpp"
#include "transport_test_util.hpp"

extern char** environ;

namespace rgbdmap::transport {
namespace {

using namespace std::chrono_literals;
using testing::Inbox;

constexpr char kPeerEnv[] = "RGBDMAP_TRANSPORT_PEER_URL";

/// Starts this binary as the NetPeer.Echo process for `url`; -1 on failure.
pid_t spawnPeer(const std::string& url) {
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) env_strings.emplace_back(*e);
  env_strings.push_back(std::string(kPeerEnv) + "=" + url);
  std::vector<char*> envp;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::string a0 = "test_transport", a1 = "--gtest_filter=NetPeer.Echo";
  char* argv[] = {a0.data(), a1.data(), nullptr};
  pid_t pid = -1;
  return posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, argv, envp.data()) == 0 ? pid : -1;
}

/// Tells the peer to quit (a few times: LCM is best effort) and reaps it; true if it exited with 0.
bool stopPeer(Transport& t, pid_t pid) {
  for (int i = 0; i < 5; ++i) t.publish("rgbdmap/robot0/quit", std::vector<uint8_t>{1});
  int status = 0;
  return waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

RGBDMAP_TEST_TIER("NetPeer.*", "elsewhere");  // run in the network namespace (transport.netns)
// The peer: keyframe -> echo, server/map -> peer/status (transient local), until quit or 30 s.
TEST(NetPeer, Echo) {
  const char* url = std::getenv(kPeerEnv);
  if (url == nullptr) GTEST_SKIP() << "helper process of the NetCrossProcess tests";
  auto made = makeTransport(url);
  ASSERT_TRUE(made.ok()) << made.error();
  Transport& t = **made;
  std::mutex m;
  std::condition_variable cv;
  bool quit = false;
  ASSERT_TRUE(t.subscribe("rgbdmap/robot0/keyframe", [&t](const std::string&, const uint8_t* d, size_t n) {
    t.publish("rgbdmap/robot0/echo", d, n);
  }));
  if (std::string(url).rfind("dds", 0) == 0) {
    ASSERT_TRUE(t.subscribe("rgbdmap/server/map", [&t](const std::string&, const uint8_t* d, size_t n) {
      t.publish("rgbdmap/peer/status", d, n);
    }));
  }
  ASSERT_TRUE(t.subscribe("rgbdmap/robot0/quit", [&](const std::string&, const uint8_t*, size_t) {
    std::lock_guard<std::mutex> lock(m);
    quit = true;
    cv.notify_all();
  }));
  ASSERT_TRUE(t.start());
  std::unique_lock<std::mutex> lock(m);
  EXPECT_TRUE(cv.wait_for(lock, 30s, [&] { return quit; }));
}

void crossProcessRoundTrip(const std::string& url) {
  if (url.rfind("dds", 0) == 0) testing::useLoopbackDdsConfig();
  auto made = makeTransport(url);
  ASSERT_TRUE(made.ok()) << made.error();
  Transport& t = **made;
  Inbox echo;
  ASSERT_TRUE(t.subscribe("rgbdmap/robot0/echo", echo.handler()));
  ASSERT_TRUE(t.start());
  const pid_t peer = spawnPeer(url);
  ASSERT_GT(peer, 0);
  const auto t0 = std::chrono::steady_clock::now();
  const bool connected = testing::waitUntilConnected(t, echo, "rgbdmap/robot0/keyframe");
  const double connect_ms = 1e3 * testing::secondsSince(t0);
  std::vector<std::vector<uint8_t>> sent;
  const auto t1 = std::chrono::steady_clock::now();
  for (uint32_t i = 0; connected && i < 10; ++i) {
    sent.push_back(testing::makePayload(i % 2 == 0 ? 32 : 300 * 1024, i + 100));
    EXPECT_TRUE(t.publish("rgbdmap/robot0/keyframe", sent.back()));
  }
  const bool all = connected && echo.waitForLongerThan(sent.size(), 1, 10s);
  std::printf("[ %s, two processes ] connected in %.0f ms; 5 x 32 B + 5 x 300 KB echoed in %.1f ms\n",
              url.c_str(), connect_ms, 1e3 * testing::secondsSince(t1));
  EXPECT_TRUE(stopPeer(t, peer));
  ASSERT_TRUE(connected);
  ASSERT_TRUE(all);
  EXPECT_EQ(echo.payloadsLongerThan(1), sent);
}

RGBDMAP_TEST_TIER("NetCrossProcess.*", "elsewhere");  // run in the network namespace (transport.netns)
TEST(NetCrossProcess, UdpmRoundTrip) {
  RGBDMAP_REQUIRE_NETNS();
  crossProcessRoundTrip(testing::kUdpmUrl);
}

TEST(NetCrossProcess, DdsRoundTrip) {
  RGBDMAP_REQUIRE_NETNS();
  crossProcessRoundTrip("dds://?domain=0");
}

TEST(NetCrossProcess, DdsLateJoinerInAnotherProcessGetsTheLatestMap) {
  RGBDMAP_REQUIRE_NETNS();
  testing::useLoopbackDdsConfig();
  auto made = makeTransport("dds://?domain=0");
  ASSERT_TRUE(made.ok()) << made.error();
  Transport& t = **made;
  const auto latest = testing::makePayload(300 * 1024, 7);
  ASSERT_TRUE(t.publish("rgbdmap/server/map", testing::makePayload(300 * 1024, 6)));
  ASSERT_TRUE(t.publish("rgbdmap/server/map", latest));
  Inbox status;  // the peer echoes what it got on rgbdmap/peer/status (also transient local)
  ASSERT_TRUE(t.subscribe("rgbdmap/peer/status", status.handler()));
  ASSERT_TRUE(t.start());
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t peer = spawnPeer("dds://?domain=0");
  ASSERT_GT(peer, 0);
  const bool got = status.waitFor(1, 10s);
  std::printf("[ late joiner, two processes ] latest map echoed %.0f ms after the peer started\n",
              1e3 * testing::secondsSince(t0));
  EXPECT_TRUE(stopPeer(t, peer));
  ASSERT_TRUE(got);
  EXPECT_EQ(status.messages[0].second, latest);
}

}  // namespace
}  // namespace rgbdmap::transport
