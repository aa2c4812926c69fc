// RobotLink on a transport that matches endpoints (as DDS does): no keyframe is published while nothing is
// matched, and a newly matched subscriber (a server starting or restarting) gets the keyframes in flight at
// once, long before their retransmission timeout.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "fake_map_server.hpp"
#include "link_test_util.hpp"
#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap {
namespace {

using namespace std::chrono_literals;
using testing::FakeMapServer;
using testing::linkKey;
using testing::linkOptions;
using testing::sendKeyframes;
using testing::serverOptions;

/// memq:// that reports a match state set by the test and, like DDS, loses what the robot publishes on a
/// keyframe channel while nothing is matched there.
class MatchingTransport final : public transport::Transport {
 public:
  explicit MatchingTransport(std::unique_ptr<transport::Transport> inner) : inner_(std::move(inner)) {}
  Status publish(const std::string& channel, const uint8_t* data, size_t size) override {
    if (current_ == 0 && channel.find("/keyframe") != std::string::npos) {
      ++lost_;
      return Status::success();
    }
    return inner_->publish(channel, data, size);
  }
  Status subscribe(const std::string& channel, Handler handler) override {
    return inner_->subscribe(channel, std::move(handler));
  }
  Status start() override { return inner_->start(); }
  void stop() override { inner_->stop(); }
  transport::TransportStats stats() const override { return inner_->stats(); }
  std::optional<transport::SubscriberMatch> matchedSubscribers(const std::string&) override {
    return transport::SubscriberMatch{current_.load(), total_.load()};
  }
  void match(int current, uint64_t total) {
    total_ = total;
    current_ = current;
  }
  int lost() const { return lost_; }

 private:
  std::unique_ptr<transport::Transport> inner_;
  std::atomic<int> current_{0}, lost_{0};
  std::atomic<uint64_t> total_{0};
};

/// Timeouts far beyond the test: only a match can explain a prompt delivery.
RobotLinkOptions slowRetransmissions(const std::string& robot, const msg::Bytes& key) {
  RobotLinkOptions o = linkOptions(robot, key);
  o.reliable.adaptive = false;
  o.reliable.initial_backoff = o.reliable.max_backoff = 30s;
  o.chunk_bytes = 0;
  return o;
}

bool storedWithin(FakeMapServer& server, size_t count, std::chrono::milliseconds limit) {
  std::unique_lock<std::mutex> lock(server.state().mutex);
  return server.state().cv.wait_for(lock, limit, [&] { return server.state().stored.size() >= count; });
}

TEST(RobotLinkMatch, NothingIsPublishedUnmatchedAndTheFirstMatchGetsEveryKeyframeAtOnce) {
  MatchingTransport transport(testing::makeMemq());
  FakeMapServer server(transport, serverOptions(linkKey(9)));
  server.start();
  RobotLink link(transport, slowRetransmissions("robot0", linkKey(9)));
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 3);
  EXPECT_FALSE(storedWithin(server, 1, 300ms));
  EXPECT_EQ(transport.lost(), 0) << "held back, not published into nothing";
  EXPECT_GE(link.stats().sends_held_unmatched, 3u);
  const auto matched = std::chrono::steady_clock::now();
  transport.match(1, 1);
  ASSERT_TRUE(storedWithin(server, 3, 5s));
  EXPECT_LT(std::chrono::steady_clock::now() - matched, 2s) << "the 30 s timeout would be far later";
  ASSERT_TRUE(link.waitAllAcked(5.0));
  EXPECT_EQ(link.stats().subscriber_matches, 1u);
  link.stop();
}

TEST(RobotLinkMatch, ARestartedServerGetsTheKeyframesInFlightAtOnce) {
  MatchingTransport transport(testing::makeMemq());
  transport.match(1, 1);
  testing::FakeServerOptions so = serverOptions(linkKey(9));
  so.ignore_first_transmissions = 2;  // the old server took them and died unanswered
  FakeMapServer server(transport, so);
  server.start();
  RobotLink link(transport, slowRetransmissions("robot0", linkKey(9)));
  ASSERT_TRUE(link.start());
  sendKeyframes(link, 2);
  EXPECT_FALSE(storedWithin(server, 1, 300ms));
  transport.match(1, 2);  // another subscriber matched while the keyframes were in flight
  ASSERT_TRUE(storedWithin(server, 2, 2s));
  ASSERT_TRUE(link.waitAllAcked(5.0));
  EXPECT_EQ(link.stats().subscriber_matches, 1u);
  EXPECT_EQ(link.stats().sends_held_unmatched, 0u);
  link.stop();
}

}  // namespace
}  // namespace rgbdmap
