// The answers repeated for duplicate chunks: KeyframeAnswers on its own (bounds, rate, first answer kept)
// and through the inbox (a robot whose KeyframeAck was lost probes with the last chunk of its transfer).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/intake/inbox.hpp"
#include "rgbdmap/intake/keyframe_answers.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/chunking.hpp"

namespace rgbdmap {
namespace {

using Clock = KeyframeAnswers::Clock;
using std::chrono::milliseconds;

TEST(KeyframeAnswers, RepeatsTheFirstAnswerAtMostOncePerInterval) {
  KeyframeAnswers answers;  // 100 ms
  const auto t0 = Clock::now();
  EXPECT_FALSE(answers.repeat("robot_1", 5, 3, t0)) << "nothing answered yet";
  answers.remember("robot_1", 5, 3, false, "images too large", t0);
  answers.remember("robot_1", 5, 3, false, "refused before", t0 + milliseconds(10));  // the first one kept
  EXPECT_FALSE(answers.repeat("robot_1", 5, 3, t0 + milliseconds(60))) << "answered 50 ms ago";
  const auto again = answers.repeat("robot_1", 5, 3, t0 + milliseconds(115));
  ASSERT_TRUE(again);
  EXPECT_EQ(again->robot_id, "robot_1");
  EXPECT_EQ(again->keyframe_id, 3);
  EXPECT_FALSE(again->accepted);
  EXPECT_EQ(again->reason, "images too large");
  EXPECT_FALSE(answers.repeat("robot_1", 6, 3, t0 + milliseconds(500))) << "another process of the robot";
  EXPECT_FALSE(answers.repeat("robot_2", 5, 3, t0 + milliseconds(500))) << "another robot";
  // A flood of duplicates, one every millisecond for a second: one answer per interval.
  int sent = 0;
  for (int ms = 116; ms < 1116; ++ms) sent += answers.repeat("robot_1", 5, 3, t0 + milliseconds(ms)) ? 1 : 0;
  EXPECT_GE(sent, 9);
  EXPECT_LE(sent, 10);
  EXPECT_EQ(answers.repeated(), static_cast<uint64_t>(sent) + 1);
}

TEST(KeyframeAnswers, BoundedPerRobotAndInAll) {
  KeyframeAnswersOptions options;
  options.per_robot = 4;
  options.total = 10;
  KeyframeAnswers answers(options);
  const auto t0 = Clock::now();
  const auto later = t0 + milliseconds(200);
  for (int id = 0; id < 50; ++id) answers.remember("robot_1", 1, id, true, "", t0);
  EXPECT_EQ(answers.size(), 4u);
  EXPECT_FALSE(answers.repeat("robot_1", 1, 45, later)) << "forgotten: older than the newest 4";
  EXPECT_TRUE(answers.repeat("robot_1", 1, 46, later));
  for (int robot = 2; robot < 10; ++robot)
    for (int id = 0; id < 4; ++id) answers.remember("robot_" + std::to_string(robot), 1, id, true, "", t0);
  EXPECT_EQ(answers.size(), 10u);
  EXPECT_TRUE(answers.repeat("robot_9", 1, 3, later)) << "the newest answer of the newest robot";
}

/// An inbox whose keyframes (whole or reassembled) are queued and never answered by themselves: the test
/// plays the ingest worker (noteAnswer) and records what goes back to the robot.
class InboxAnswers : public ::testing::Test {
 protected:
  static constexpr int64_t kSession = 77;
  InboxAnswers()
      : chunk_signer_("robot_1", testing::testKey(1), kSession),
        keyframe_signer_("robot_1", testing::testKey(1), kSession) {
    EXPECT_TRUE(keys_.add("robot_1", testing::testKey(1)));
  }

  std::unique_ptr<Inbox> makeInbox(double repeat_interval_s) {
    InboxConfig config;
    config.answers.repeat_interval_s = repeat_interval_s;
    InboxQueue queue;
    queue.hello = [](msg::Hello) {};
    queue.keyframe = [this](msg::Keyframe kf, size_t) {
      queued_.push_back(kf.keyframe_id);
      return RobotQueues::Pushed::kQueued;
    };
    queue.demote = [](const std::string&) {};
    auto inbox = std::make_unique<Inbox>(config, keys_, registry_, queue);
    inbox->setChunkAckSink(
        [this](const std::string&, const msg::ChunkAck& ack) { chunk_acks_.push_back(ack); });
    inbox->setKeyframeAckSink(
        [this](const std::string&, const msg::KeyframeAck& ack) { keyframe_acks_.push_back(ack); });
    return inbox;
  }
  /// Keyframe `id` sealed whole and cut into the smallest chunks (transfer id = id).
  std::vector<msg::KeyframeChunk> chunksOf(int id) {
    msg::Keyframe kf = testing::sampleKeyframe();
    kf.robot_id = "robot_1";
    kf.keyframe_id = id;
    kf.previous_keyframe_id = id - 1;
    std::vector<msg::KeyframeChunk> chunks;
    const Result<msg::Bytes> sealed = keyframe_signer_.seal(kf, 1000);
    EXPECT_TRUE(sealed) << sealed.error();
    if (!sealed) return chunks;
    const msg::Bytes& envelope = *sealed;
    for (int i = 0; i < msg::chunkCount(envelope.size(), msg::kMinChunkBytes); ++i)
      chunks.push_back(msg::makeChunk(envelope, msg::kMinChunkBytes, i, "robot_1", id, id).value());
    if (!chunks.empty()) chunks.back().last_of_burst = true;
    return chunks;
  }
  void deliver(Inbox& inbox, const msg::KeyframeChunk& chunk) {
    const msg::Bytes sealed = chunk_signer_.seal(chunk, 1000).value();
    inbox.onMessage(*msg::channelFor(msg::MessageType::kKeyframeChunk, "robot_1"), sealed.data(),
                    sealed.size());
  }

  msg::KeyStore keys_;
  msg::Signer chunk_signer_, keyframe_signer_;
  RobotRegistry registry_;
  std::vector<int> queued_;
  std::vector<msg::ChunkAck> chunk_acks_;
  std::vector<msg::KeyframeAck> keyframe_acks_;
};

TEST_F(InboxAnswers, AProbeOfAStoredKeyframeGetsItsAckAgainButNotBeforeItIsAnswered) {
  auto inbox = makeInbox(0.0);
  const auto chunks = chunksOf(4);
  ASSERT_GT(chunks.size(), 2u);
  for (const auto& c : chunks) deliver(*inbox, c);
  ASSERT_EQ(queued_, std::vector<int>{4});
  ASSERT_EQ(chunk_acks_.size(), 1u) << "the completing chunk";
  // Complete, queued, not stored yet: the probe gets "all received" but no KeyframeAck.
  deliver(*inbox, chunks.back());
  ASSERT_EQ(chunk_acks_.size(), 2u);
  for (int i = 0; i < chunk_acks_[1].chunk_count; ++i)
    EXPECT_TRUE(msg::chunkReceived(chunk_acks_[1].received, i));
  EXPECT_TRUE(keyframe_acks_.empty()) << "a keyframe still queued is not acknowledged early";
  // Stored and acknowledged by the ingest worker; that ack is lost. The next probe gets it again.
  inbox->noteAnswer("robot_1", kSession, 4, true, "");
  deliver(*inbox, chunks.back());
  ASSERT_EQ(keyframe_acks_.size(), 1u);
  EXPECT_EQ(keyframe_acks_[0].keyframe_id, 4);
  EXPECT_TRUE(keyframe_acks_[0].accepted);
  EXPECT_EQ(queued_.size(), 1u) << "the probe starts no new transfer";
  // A duplicate that is not the last of a burst (a late copy) asks for nothing.
  deliver(*inbox, chunks.front());
  EXPECT_EQ(keyframe_acks_.size(), 1u);
  EXPECT_EQ(inbox->stats().keyframe_acks_repeated, 1u);
}

TEST_F(InboxAnswers, AFloodOfProbesGetsNoMoreAcksThanTheInterval) {
  auto inbox = makeInbox(3600.0);
  const auto chunks = chunksOf(2);
  for (const auto& c : chunks) deliver(*inbox, c);
  inbox->noteAnswer("robot_1", kSession, 2, false, "refused for the test");
  for (int i = 0; i < 200; ++i) deliver(*inbox, chunks.back());
  EXPECT_TRUE(keyframe_acks_.empty()) << "answered moments ago: the interval counts the first answer";
  EXPECT_EQ(chunk_acks_.size(), 201u) << "every probe still gets its ChunkAck";
  EXPECT_EQ(inbox->stats().keyframe_acks_repeated, 0u);
}

TEST_F(InboxAnswers, OnlyTheAnsweredKeyframeOfThisSessionIsRepeated) {
  auto inbox = makeInbox(0.0);
  const auto first = chunksOf(1);
  const auto second = chunksOf(2);
  for (const auto& c : first) deliver(*inbox, c);
  for (const auto& c : second) deliver(*inbox, c);
  inbox->noteAnswer("robot_1", kSession + 1, 1, true, "");  // another process of the robot
  inbox->noteAnswer("robot_1", kSession, 2, false, "bad depth");
  deliver(*inbox, first.back());
  EXPECT_TRUE(keyframe_acks_.empty());
  deliver(*inbox, second.back());
  ASSERT_EQ(keyframe_acks_.size(), 1u);
  EXPECT_EQ(keyframe_acks_[0].keyframe_id, 2);
  EXPECT_FALSE(keyframe_acks_[0].accepted) << "refused as first answered";
  EXPECT_EQ(keyframe_acks_[0].reason, "bad depth");
}

}  // namespace
}  // namespace rgbdmap
