// RobotLink's chunked keyframes against a scripted server over memq://: which chunks of a burst are flagged
// last-of-burst, which chunks a ChunkAck makes the link send again (only those a chunk sent after them shows
// lost, never those still on their way), and the Hello to a server heard before it registered the robot.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "link_test_util.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap {
namespace {

using testing::linkKey;
using testing::linkOptions;
using testing::smallFrame;
using testing::smallKeyframe;
using testing::testPose;

struct SentChunk {
  int index = 0;
  bool flagged = false;  ///< last_of_burst
};

/// Records the chunks robot0 sends (in the order sent) and answers them with the ChunkAcks a test scripts.
class ChunkScript {
 public:
  ChunkScript(transport::Transport& transport, const msg::Bytes& key)
      : transport_(transport), server_(msg::kServerId, key), state_(std::make_shared<State>()) {
    EXPECT_TRUE(state_->keys.add("robot0", key));
    auto state = state_;  // the handler outlives this object (no unsubscribe)
    EXPECT_TRUE(transport_.subscribe(*msg::channelFor(msg::MessageType::kKeyframeChunk, "robot0"),
                                     [state](const std::string&, const uint8_t* data, size_t size) {
                                       auto opened = msg::openEnvelope(data, size, state->keys, nullptr);
                                       if (!opened) return;
                                       auto chunk = msg::decodeMessage<msg::KeyframeChunk>(*opened);
                                       if (!chunk) return;
                                       std::lock_guard<std::mutex> lock(state->mutex);
                                       state->sent.push_back({chunk->chunk_index, chunk->last_of_burst});
                                       state->last = *chunk;
                                     }));
  }

  /// The chunks sent so far, once there are at least `n` (at most 5 s), or `n` = 0 and the first burst is
  /// out.
  std::vector<SentChunk> sent(size_t n = 0) const {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (std::chrono::steady_clock::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(state_->mutex);
        const size_t want = n > 0 ? n : static_cast<size_t>(state_->last.chunk_count);
        if (!state_->sent.empty() && state_->sent.size() >= want) return state_->sent;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::lock_guard<std::mutex> lock(state_->mutex);
    return state_->sent;
  }

  /// Answers with a ChunkAck saying that every chunk but `missing` arrived, and that `shown` more did not
  /// (yet): chunks >= shown are left out as well.
  void ack(const std::vector<int>& missing, int shown) {
    msg::ChunkAck ack;
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      ack.robot_id = "robot0";
      ack.transfer_id = state_->last.transfer_id;
      ack.keyframe_id = state_->last.keyframe_id;
      ack.chunk_count = state_->last.chunk_count;
    }
    ack.received.assign(static_cast<size_t>((ack.chunk_count + 7) / 8), 0);
    for (int i = 0; i < std::min(shown, ack.chunk_count); ++i)
      if (std::find(missing.begin(), missing.end(), i) == missing.end())
        ack.received[static_cast<size_t>(i / 8)] |= static_cast<uint8_t>(1u << (i % 8));
    Result<msg::Bytes> bytes = server_.seal(ack, 1);
    ASSERT_TRUE(bytes) << bytes.error();
    ASSERT_TRUE(transport_.publish(*msg::channelFor(msg::MessageType::kChunkAck, "robot0"), bytes->data(),
                                   bytes->size()));
  }

 private:
  struct State {
    std::mutex mutex;
    msg::KeyStore keys;
    std::vector<SentChunk> sent;
    msg::KeyframeChunk last;
  };
  transport::Transport& transport_;
  msg::Signer server_;
  std::shared_ptr<State> state_;
};

/// Small chunks (a keyframe of the 64x48 test frame is some dozens) and timeouts far beyond the test: every
/// chunk sent again here answers a ChunkAck.
RobotLinkOptions chunkedLink() {
  RobotLinkOptions o = linkOptions("robot0", linkKey(1));
  o.chunk_bytes = msg::kMinChunkBytes;
  o.reliable.initial_backoff = o.reliable.min_backoff = std::chrono::milliseconds(4000);
  o.reliable.max_backoff = std::chrono::milliseconds(8000);
  return o;
}

/// Indices of `chunks` from position `from` on.
std::vector<int> indicesFrom(const std::vector<SentChunk>& chunks, size_t from) {
  std::vector<int> out;
  for (size_t k = from; k < chunks.size(); ++k) out.push_back(chunks[k].index);
  return out;
}

TEST(RobotLinkChunks, TheLastThreeChunksOfABurstAreFlaggedAndProvenLossesResent) {
  auto transport = testing::makeMemq();
  ChunkScript server(*transport, linkKey(1));
  RobotLink link(*transport, chunkedLink());
  ASSERT_TRUE(link.start());
  ASSERT_TRUE(link.sendKeyframe(smallKeyframe(0, 0, testPose(0)), smallFrame(0)));
  const std::vector<SentChunk> first = server.sent();
  const int n = static_cast<int>(first.size());
  ASSERT_GE(n, 8);
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(first[static_cast<size_t>(k)].index, k);
    EXPECT_EQ(first[static_cast<size_t>(k)].flagged, k >= n - 3) << "chunk " << k << " of " << n;
  }
  server.ack({1, 4}, n);  // the last chunk's answer: 1 and 4 were lost
  const std::vector<SentChunk> again = server.sent(static_cast<size_t>(n) + 2);
  ASSERT_EQ(again.size(), static_cast<size_t>(n) + 2);
  EXPECT_EQ(indicesFrom(again, static_cast<size_t>(n)), (std::vector<int>{1, 4}));
  EXPECT_TRUE(again[static_cast<size_t>(n)].flagged && again[static_cast<size_t>(n) + 1].flagged)
      << "a burst of fewer than three chunks is flagged whole";
  server.ack({}, n);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(server.sent().size(), static_cast<size_t>(n) + 2) << "nothing missing, nothing resent";
  link.stop();
}

// The first flagged chunk's ChunkAck shows the two after it as missing: they are on their way, not lost.
// Only chunk 2 (sent before a chunk that arrived) is resent; the later answers of the same burst show the
// resent chunk 2 missing again, which was sent after them: nothing more goes out.
TEST(RobotLinkChunks, AnAckOfAnEarlierFlaggedChunkResendsNoChunkStillOnItsWay) {
  auto transport = testing::makeMemq();
  ChunkScript server(*transport, linkKey(1));
  RobotLink link(*transport, chunkedLink());
  ASSERT_TRUE(link.start());
  ASSERT_TRUE(link.sendKeyframe(smallKeyframe(0, 0, testPose(0)), smallFrame(0)));
  const int n = static_cast<int>(server.sent().size());
  ASSERT_GE(n, 8);
  server.ack({2}, n - 2);  // answers chunk n-3: n-2 and n-1 not there yet
  const std::vector<SentChunk> after_first = server.sent(static_cast<size_t>(n) + 1);
  EXPECT_EQ(indicesFrom(after_first, static_cast<size_t>(n)), (std::vector<int>{2}));
  server.ack({2}, n - 1);  // answers chunk n-2
  server.ack({2}, n);      // answers chunk n-1
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(indicesFrom(server.sent(), static_cast<size_t>(n)), (std::vector<int>{2}))
      << "chunk 2 was resent after the chunks these ChunkAcks answer";
  server.ack({}, n);  // the resent chunk 2 arrived
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(server.sent().size(), static_cast<size_t>(n) + 1);
  const RobotLinkStats s = link.stats();
  EXPECT_EQ(s.chunks_resent, 1u);
  EXPECT_EQ(s.retransmissions, 0u) << "no timeout fired";
  link.stop();
}

// Chunk n-3 is lost, so is the ChunkAck of n-2: the answer of n-1 shows n-3 missing and it is resent.
TEST(RobotLinkChunks, ALostFlaggedChunkIsResentOnTheNextFlaggedChunksAnswer) {
  auto transport = testing::makeMemq();
  ChunkScript server(*transport, linkKey(1));
  RobotLink link(*transport, chunkedLink());
  ASSERT_TRUE(link.start());
  ASSERT_TRUE(link.sendKeyframe(smallKeyframe(0, 0, testPose(0)), smallFrame(0)));
  const int n = static_cast<int>(server.sent().size());
  ASSERT_GE(n, 8);
  server.ack({n - 3}, n);
  EXPECT_EQ(indicesFrom(server.sent(static_cast<size_t>(n) + 1), static_cast<size_t>(n)),
            (std::vector<int>{n - 3}));
  link.stop();
}

// The server answers chunks but has not shown it registered the robot (its Hello was lost, and it holds the
// keyframes until one arrives): the robot says Hello again within 0.2 s, not after hello_period_s.
TEST(RobotLinkChunks, AServerHeardBeforeItKnowsTheRobotGetsHellosSoon) {
  auto transport = testing::makeMemq();
  ChunkScript server(*transport, linkKey(1));
  auto hellos = std::make_shared<std::atomic<int>>(0);
  ASSERT_TRUE(transport->subscribe(*msg::channelFor(msg::MessageType::kHello, "robot0"),
                                   [hellos](const std::string&, const uint8_t*, size_t) { ++*hellos; }));
  RobotLinkOptions options = chunkedLink();
  options.hello_period_s = 30.0;
  RobotLink link(*transport, options);
  ASSERT_TRUE(link.start());
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(hellos->load(), 1) << "the first Hello only: no server heard";
  ASSERT_TRUE(link.sendKeyframe(smallKeyframe(0, 0, testPose(0)), smallFrame(0)));
  server.ack({}, static_cast<int>(server.sent().size()));  // heard; a ChunkAck is no registration
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  EXPECT_GE(hellos->load(), 4) << "about every 0.2 s";
  EXPECT_LE(hellos->load(), 8);
  link.stop();
}

}  // namespace
}  // namespace rgbdmap
