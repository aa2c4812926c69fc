// Keyframes in chunks (RobotLink chunk_bytes > 0) to the real MapServer: every keyframe stored and
// acknowledged despite lost chunks (in-process, a transport that drops publishes), a lost KeyframeAck
// repeated for the robot's probe (and a new transfer when a restarted server forgot it), forged chunks
// rejected and counted; and (NetChunk, in a network namespace) over udpm:// through rgbdmap-lossy-relay
// at 5 % packet loss, where whole ~140 KB keyframes over LCM almost never arrive.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <random>

#include "link/link_test_util.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/proto/chunking.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "server/server_test_util.hpp"
#include "test_tier.hpp"

extern char** environ;

namespace rgbdmap {
namespace {

using namespace rgbdmap::testing;  // NOLINT: the shared test helpers

/// Drops each publish with probability `loss` (seeded): message loss at the sender.
class DroppingTransport : public transport::Transport {
 public:
  DroppingTransport(transport::Transport& inner, double loss, uint64_t seed)
      : inner_(inner), loss_(loss), rng_(seed) {}
  Status publish(const std::string& channel, const uint8_t* data, size_t size) override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < loss_) return Status::success();
    }
    return inner_.publish(channel, data, size);
  }
  Status subscribe(const std::string& channel, Handler handler) override {
    return inner_.subscribe(channel, handler);
  }
  Status start() override { return inner_.start(); }
  void stop() override {}
  transport::TransportStats stats() const override { return inner_.stats(); }
  void setLoss(double loss) {
    std::lock_guard<std::mutex> lock(mutex_);
    loss_ = loss;
  }

 private:
  transport::Transport& inner_;
  double loss_;
  std::mutex mutex_;
  std::mt19937_64 rng_;
};

/// Drops the messages delivered on `channel` while blocked, and the first `drop_first` of them: answers lost
/// on their way back to the robot.
class LosingAnswers : public transport::Transport {
 public:
  LosingAnswers(transport::Transport& inner, std::string channel, int drop_first)
      : inner_(inner), channel_(std::move(channel)), state_(std::make_shared<State>()) {
    state_->drop_first = drop_first;
  }
  Status publish(const std::string& channel, const uint8_t* data, size_t size) override {
    return inner_.publish(channel, data, size);
  }
  Status subscribe(const std::string& channel, Handler handler) override {
    if (channel != channel_) return inner_.subscribe(channel, handler);
    return inner_.subscribe(channel,
                            [state = state_, handler](const std::string& c, const uint8_t* d, size_t n) {
                              if (state->blocked || state->drop_first.fetch_sub(1) > 0) {
                                ++state->dropped;
                                return;
                              }
                              handler(c, d, n);
                            });
  }
  Status start() override { return inner_.start(); }
  void stop() override {}
  transport::TransportStats stats() const override { return inner_.stats(); }
  void block(bool blocked) { state_->blocked = blocked; }
  int dropped() const { return state_->dropped; }

 private:
  struct State {
    std::atomic<bool> blocked{false};
    std::atomic<int> drop_first{0}, dropped{0};
  };
  transport::Transport& inner_;
  const std::string channel_;
  std::shared_ptr<State> state_;
};

/// A frame of colour noise: 320x240 ~70 KB per keyframe on the wire, 448x336 ~140 KB (a real keyframe).
RgbdFrame noiseFrame(int seed, int width, int height) {
  RgbdFrame f;
  f.timestamp = 100.0 + seed;
  f.color.create(height, width, CV_8UC3);
  cv::theRNG().state = static_cast<uint64_t>(seed + 1);
  cv::randu(f.color, cv::Scalar::all(0), cv::Scalar::all(255));
  f.depth = cv::Mat(height, width, CV_16UC1, cv::Scalar(7500));
  return f;
}

RobotLinkOptions chunkedOptions(const std::string& robot, const msg::Bytes& key, int chunk_bytes,
                                int width = 320, int height = 240) {
  RobotLinkOptions o = linkOptions(robot, key);
  o.camera = CameraIntrinsics{525.0, 525.0,  0.5 * (width - 1), 0.5 * (height - 1),
                              width, height, {0, 0, 0, 0, 0},   5000.0, 0.0};
  o.chunk_bytes = chunk_bytes;
  o.reliable.max_attempts = 1000;  // bounded by the test's wait, not by attempts
  return o;
}

/// Sends `count` keyframes (a chain) and waits up to `timeout_s` for their acks; returns the acked count.
uint64_t sendAndWait(RobotLink& link, int count, double timeout_s, int width = 320, int height = 240) {
  for (int i = 0; i < count; ++i) {
    const Status s = link.sendKeyframe(smallKeyframe(i, 0, testPose(i), i - 1), noiseFrame(i, width, height));
    EXPECT_TRUE(s) << s.error();
  }
  link.waitAllAcked(timeout_s);
  return link.stats().keyframes_acked;
}

RGBDMAP_TEST_TIER("ChunkedDelivery.*", "e2e");
RGBDMAP_TEST_TIER("ChunkedDelivery.LostChunksAreResentUntilEveryKeyframeIsStored", "e2e sanitize");
TEST(ChunkedDelivery, LostChunksAreResentUntilEveryKeyframeIsStored) {
  const std::string dir = freshDir("chunked_loss");
  ServerHarness harness(serverTestConfig(dir, {"robot0"}));
  DroppingTransport lossy(*harness.transport, 0.05, 7);
  RobotLink link(lossy, chunkedOptions("robot0", testKey(1), 1100));
  ASSERT_TRUE(link.start());
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(sendAndWait(link, 6, 20.0), 6u);
  const RobotLinkStats s = link.stats();
  std::printf(
      "chunked memq 5%% publish loss: 6 keyframes acked in %.2f s, %llu chunks sent, %llu resent, %llu "
      "bytes\n",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
      static_cast<unsigned long long>(s.chunks_sent), static_cast<unsigned long long>(s.chunks_resent),
      static_cast<unsigned long long>(s.bytes_sent));
  EXPECT_GT(s.chunks_resent, 0u);
  // Acknowledged = stored; their placement into the graph may still be running.
  EXPECT_TRUE(harness.server->waitIdle(30.0));
  EXPECT_GE(harness.server->stats().keyframes, 6);
  link.stop();
  std::filesystem::remove_all(dir);
}

// A robot that starts before its server: its first Hello and chunks are lost. The server answers the
// resent chunks with ChunkAcks before any Hello; the robot must not take them for a registration (it
// stopped saying Hello, and its keyframes waited for that Hello for good).
TEST(ChunkedDelivery, ARobotStartedBeforeItsServerSaysHelloUntilRegistered) {
  const std::string dir = freshDir("chunked_early");
  ServerHarness harness(serverTestConfig(dir, {"robot0"}));
  DroppingTransport not_yet(*harness.transport, 1.0, 3);  // everything lost: no server yet
  RobotLinkOptions options = chunkedOptions("robot0", testKey(1), 1100);
  options.hello_period_s = 2.0;  // the resent chunks' ChunkAcks come well before the next Hello
  RobotLink link(not_yet, options);
  ASSERT_TRUE(link.start());
  for (int i = 0; i < 3; ++i)
    ASSERT_TRUE(link.sendKeyframe(smallKeyframe(i, 0, testPose(i), i - 1), noiseFrame(i, 320, 240)));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  not_yet.setLoss(0.0);  // the server is up
  EXPECT_TRUE(link.waitAllAcked(15.0)) << link.stats().keyframes_acked << " of 3 acknowledged";
  EXPECT_TRUE(harness.server->waitIdle(30.0));  // acknowledged = stored; placed into the graph after
  EXPECT_EQ(harness.server->stats().keyframes, 3);
  link.stop();
  std::filesystem::remove_all(dir);
}

// The one KeyframeAck of a keyframe is lost. Every chunk arrived, so the robot probes with the transfer's
// last chunk and the server, having stored the keyframe, answers it with the ack again: no second transfer.
RGBDMAP_TEST_TIER("ChunkedDelivery.ALostKeyframeAckIsRepeatedForAProbeWithoutANewTransfer", "e2e sanitize");
TEST(ChunkedDelivery, ALostKeyframeAckIsRepeatedForAProbeWithoutANewTransfer) {
  const std::string dir = freshDir("chunked_lost_ack");
  ServerHarness harness(serverTestConfig(dir, {"robot0"}));
  LosingAnswers lossy(*harness.transport, *msg::channelFor(msg::MessageType::kKeyframeAck, "robot0"), 0);
  RobotLink link(lossy, chunkedOptions("robot0", testKey(1), 1100));
  ASSERT_TRUE(link.start());
  EXPECT_EQ(sendAndWait(link, 1, 10.0), 1u);  // keyframe 0 as usual: one transfer
  const RobotLinkStats first = link.stats();
  // A store slower than the timeout (a loaded machine) is probed with the last chunk, never resent whole.
  EXPECT_LE(first.chunks_resent, 5u);
  lossy.block(true);  // keyframe 1's ack is lost (and any repeat before the robot probes)
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_TRUE(link.sendKeyframe(smallKeyframe(1, 0, testPose(1), 0), noiseFrame(1, 320, 240)));
  for (int i = 0; i < 200 && lossy.dropped() == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(lossy.dropped(), 1) << "the first KeyframeAck of keyframe 1";
  lossy.block(false);
  EXPECT_TRUE(link.waitAllAcked(10.0));
  link.stop();  // every send counted
  const RobotLinkStats s = link.stats();
  const uint64_t chunks = s.chunks_sent - first.chunks_sent, resent = s.chunks_resent - first.chunks_resent;
  std::printf(
      "lost KeyframeAck: acknowledged after %.3f s, %llu chunks sent (%llu resent; keyframe 0: %llu)\n",
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
      static_cast<unsigned long long>(chunks), static_cast<unsigned long long>(resent),
      static_cast<unsigned long long>(first.chunks_sent));
  EXPECT_EQ(s.keyframes_acked, 2u);
  EXPECT_GE(resent, 1u) << "at least one probe";
  EXPECT_LE(resent, 10u) << "probes only";
  EXPECT_LT(chunks - resent, first.chunks_sent * 3 / 2) << "one transfer of keyframe 1, not two";
  const MapServerStats server = harness.server->stats();
  EXPECT_GE(server.inbox.keyframe_acks_repeated, 1u);
  ASSERT_EQ(server.robots.size(), 1u);
  EXPECT_EQ(server.robots[0].duplicates, 0u) << "no second copy of keyframe 1 reached the ingest";
  std::filesystem::remove_all(dir);
}

// The server stored a keyframe, its ack was lost, and it restarted before the robot probed: the restarted
// server knows no transfer and no answer, so it takes the probe for the first chunk of a new transfer and
// answers with one bit set. The robot does not take that for missing chunks; it seals a new transfer after
// its reseal wait, and the server acknowledges the restored keyframe as a duplicate.
RGBDMAP_TEST_TIER("ChunkedDelivery.AProbeToARestartedServerEndsInANewTransfer", "e2e sanitize");
TEST(ChunkedDelivery, AProbeToARestartedServerEndsInANewTransfer) {
  const std::string dir = freshDir("chunked_restart_probe");
  const MapServerConfig config = serverTestConfig(dir, {"robot0"});
  ServerHarness harness(config);
  LosingAnswers lossy(*harness.transport, *msg::channelFor(msg::MessageType::kKeyframeAck, "robot0"), 0);
  RobotLink link(lossy, chunkedOptions("robot0", testKey(1), 1100));
  ASSERT_TRUE(link.start());
  lossy.block(true);
  ASSERT_TRUE(link.sendKeyframe(smallKeyframe(0, 0, testPose(0), -1), noiseFrame(0, 320, 240)));
  for (int i = 0; i < 400 && lossy.dropped() == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_GE(lossy.dropped(), 1) << "stored and acknowledged, the ack lost";
  harness.server->stop();
  harness.server.reset();
  harness.start(config);
  lossy.block(false);
  EXPECT_TRUE(link.waitAllAcked(15.0));
  link.stop();  // every send counted
  const RobotLinkStats s = link.stats();
  std::printf("probe to a restarted server: %llu chunks sent (%llu resent), %llu ChunkAcks\n",
              static_cast<unsigned long long>(s.chunks_sent),
              static_cast<unsigned long long>(s.chunks_resent),
              static_cast<unsigned long long>(s.chunk_acks));
  EXPECT_EQ(s.keyframes_acked, 1u);
  EXPECT_LT(s.chunk_acks, 40u) << "no ping-pong of ChunkAcks";
  EXPECT_EQ(harness.server->stats().restored_keyframes, 1);
  std::filesystem::remove_all(dir);
}

RGBDMAP_TEST_TIER("ChunkedDelivery.ForgedAndWrongKeyChunksAreRejectedAndCounted", "e2e sanitize");
TEST(ChunkedDelivery, ForgedAndWrongKeyChunksAreRejectedAndCounted) {
  const std::string dir = freshDir("chunked_forged");
  ServerHarness harness(serverTestConfig(dir, {"robot0"}));
  const std::string channel = *msg::channelFor(msg::MessageType::kKeyframeChunk, "robot0");
  msg::Signer wrong_key("robot0", testKey(9));
  msg::Bytes envelope(5000, 0x42);
  for (int i = 0; i < 5; ++i) {
    msg::KeyframeChunk c = msg::makeChunk(envelope, 1200, i, "robot0", 1, 1).value();
    const msg::Bytes bytes = wrong_key.seal(c, 1).value();
    ASSERT_TRUE(harness.transport->publish(channel, bytes.data(), bytes.size()));
    msg::Bytes truncated(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(bytes.size() / 2));
    ASSERT_TRUE(harness.transport->publish(channel, truncated.data(), truncated.size()));
  }
  // Correctly signed chunks whose reassembled bytes are not a keyframe envelope: rejected once, no crash.
  msg::Signer robot("robot0", testKey(1));
  for (int i = 0; i < 5; ++i) {
    msg::KeyframeChunk c = msg::makeChunk(envelope, 1200, i, "robot0", 1, 2).value();
    const msg::Bytes bytes = robot.seal(c, 1).value();
    ASSERT_TRUE(harness.transport->publish(channel, bytes.data(), bytes.size()));
  }
  for (int i = 0; i < 100 && harness.server->stats().inbox.messages_rejected < 11; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(harness.server->stats().inbox.messages_rejected, 11u);
  EXPECT_EQ(harness.server->stats().keyframes, 0);
  std::filesystem::remove_all(dir);
}

/// rgbdmap-lossy-relay next to this test binary, between the robots' and the server's LCM endpoints.
class Relay {
 public:
  explicit Relay(const std::vector<std::string>& args) {
    const std::string exe =
        (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "rgbdmap-lossy-relay").string();
    std::vector<std::string> all = {exe};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, exe.c_str(), nullptr, nullptr, argv.data(), environ) != 0) pid_ = -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  }
  ~Relay() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
  bool ok() const { return pid_ > 0; }

 private:
  pid_t pid_ = -1;
};

RGBDMAP_TEST_TIER("NetChunk.*", "elsewhere");
TEST(NetChunk, EveryKeyframeAcknowledgedThroughFivePercentPacketLoss) {
  if (std::getenv("RGBDMAP_TRANSPORT_NETNS") == nullptr) GTEST_SKIP() << "only inside run_in_netns.sh";
  const char* env_chunk = std::getenv("RGBDMAP_TEST_CHUNK_BYTES");
  const int chunk_bytes = env_chunk ? std::atoi(env_chunk) : 1100;
  const char* env_loss = std::getenv("RGBDMAP_TEST_PACKET_LOSS");
  const std::string loss = env_loss ? env_loss : "0.05";
  const std::string robots_url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608";
  const std::string server_url = "udpm://239.255.76.68:7668?ttl=0&recv_buf_size=8388608";
  Relay relay({"--a", robots_url, "--b", server_url, "--drop-datagrams", loss, "--mtu", "1500", "--seed",
               "11", "--duration", "60"});
  ASSERT_TRUE(relay.ok());
  const std::string dir = freshDir("netchunk");
  auto server_transport = transport::makeTransport(server_url).value();
  msg::KeyStore keys;
  ASSERT_TRUE(keys.add("robot0", testKey(1)));
  MapServer server(serverTestConfig(dir, {"robot0"}), *server_transport, std::move(keys));
  ASSERT_TRUE(server.start());
  ASSERT_TRUE(server_transport->start());
  auto robot_transport = transport::makeTransport(robots_url).value();
  RobotLinkOptions options = chunkedOptions("robot0", testKey(1), chunk_bytes, 448, 336);
  options.reliable = transport::ReliableSenderOptions{};  // the production timers: 100 ms .. 2 s, 20 attempts
  RobotLink link(*robot_transport, options);
  ASSERT_TRUE(link.start());
  const int count = 10;
  const auto t0 = std::chrono::steady_clock::now();
  const uint64_t acked = sendAndWait(link, count, 20.0, 448, 336);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const RobotLinkStats s = link.stats();
  std::printf(
      "udpm %s packet loss, chunk_bytes %d: %llu/%d keyframes acked in %.2f s; %llu bytes sent, "
      "%llu chunks (%llu resent), %llu keyframe retransmissions, %llu given up, server stored %d\n",
      loss.c_str(), chunk_bytes, static_cast<unsigned long long>(acked), count, seconds,
      static_cast<unsigned long long>(s.bytes_sent), static_cast<unsigned long long>(s.chunks_sent),
      static_cast<unsigned long long>(s.chunks_resent), static_cast<unsigned long long>(s.retransmissions),
      static_cast<unsigned long long>(s.keyframes_given_up), server.stats().keyframes);
  if (chunk_bytes > 0) {
    EXPECT_EQ(acked, static_cast<uint64_t>(count));
  }
  link.stop();
  robot_transport->stop();
  server_transport->stop();
  server.stop();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rgbdmap
