// The inbox on its own, with a scripted queue behind it: what it hands on, what it counts (InboxStats and the
// robot's ServerRobotStats) and whom it demotes.
#include <gtest/gtest.h>

#include <deque>
#include <string>
#include <vector>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/intake/inbox.hpp"
#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap {
namespace {

struct ScriptedQueue {
  std::vector<std::string> hellos, keyframes, demoted;
  std::deque<RobotQueues::Pushed> answers;  ///< kQueued once they run out

  InboxQueue calls() {
    InboxQueue q;
    q.hello = [this](msg::Hello hello) { hellos.push_back(hello.robot_id); };
    q.keyframe = [this](msg::Keyframe keyframe, size_t) {
      keyframes.push_back(keyframe.robot_id + "/" + std::to_string(keyframe.keyframe_id));
      if (answers.empty()) return RobotQueues::Pushed::kQueued;
      const RobotQueues::Pushed answer = answers.front();
      answers.pop_front();
      return answer;
    };
    q.demote = [this](const std::string& robot) { demoted.push_back(robot); };
    return q;
  }
};

class InboxTest : public ::testing::Test {
 protected:
  InboxTest() : signer_("robot_1", testing::testKey(1)) {
    EXPECT_TRUE(keys_.add("robot_1", testing::testKey(1)));
  }

  template <typename T>
  void deliver(Inbox& inbox, const T& message, msg::Signer& signer) {
    const Result<msg::Bytes> sealed = signer.seal(message, 1000);
    ASSERT_TRUE(sealed) << sealed.error();
    inbox.onMessage(msg::channelFor(T::kType, signer.sender()).value(), sealed->data(), sealed->size());
  }
  msg::Keyframe keyframe(int id, const std::string& robot = "robot_1") const {
    msg::Keyframe k = kf_;
    k.robot_id = robot;
    k.keyframe_id = id;
    k.previous_keyframe_id = id - 1;
    return k;
  }

  msg::KeyStore keys_;
  msg::Signer signer_;
  RobotRegistry registry_;
  ScriptedQueue queue_;
  const msg::Keyframe kf_ = testing::sampleKeyframe(10);
};

TEST_F(InboxTest, HandsOnHellosAndKeyframesAndCountsWhatTheQueueRefuses) {
  Inbox inbox({}, keys_, registry_, queue_.calls());
  deliver(inbox, testing::sampleHello(), signer_);
  ASSERT_TRUE(registry_.hello("robot_1", 1, CameraIntrinsics{}));
  queue_.answers = {RobotQueues::Pushed::kQueued, RobotQueues::Pushed::kFull,
                    RobotQueues::Pushed::kDuplicate};
  for (int id = 1; id <= 3; ++id) deliver(inbox, keyframe(id), signer_);
  EXPECT_EQ(queue_.hellos, std::vector<std::string>{"robot_1"});
  EXPECT_EQ(queue_.keyframes, (std::vector<std::string>{"robot_1/1", "robot_1/2", "robot_1/3"}));
  EXPECT_EQ(queue_.demoted, std::vector<std::string>{"robot_1"}) << "only a full queue demotes";
  const InboxStats s = inbox.stats();
  EXPECT_EQ(s.keyframes_dropped_queue_full, 1u);
  EXPECT_EQ(s.keyframes_duplicates_queued, 1u);
  EXPECT_EQ(s.keyframes_throttled, 0u);
  EXPECT_EQ(s.messages_rejected, 0u);
  const ServerRobotStats robot = registry_.stats().at(0);
  EXPECT_EQ(robot.queue_full, 1u);
  EXPECT_EQ(robot.duplicates_queued, 1u);
  EXPECT_GT(robot.bytes_received, 0u);
}

TEST_F(InboxTest, OverTheRateIsThrottledBeforeTheQueueAndTheRobotDemoted) {
  InboxConfig config;
  config.max_keyframes_per_s = 0.001;  // no refill within the test
  config.keyframe_burst = 2.0;
  Inbox inbox(config, keys_, registry_, queue_.calls());
  for (int id = 1; id <= 5; ++id) deliver(inbox, keyframe(id), signer_);
  EXPECT_EQ(queue_.keyframes.size(), 2u);
  EXPECT_EQ(queue_.demoted.size(), 3u);
  EXPECT_EQ(inbox.stats().keyframes_throttled, 3u);
}

TEST_F(InboxTest, WrongKeysAndRobotsOutsideTheListAreCountedNotQueued) {
  InboxConfig config;
  config.robots = {"robot_2"};
  Inbox listed(config, keys_, registry_, queue_.calls());
  deliver(listed, keyframe(1), signer_);
  EXPECT_EQ(listed.stats().unknown_robot_messages, 1u);

  Inbox inbox({}, keys_, registry_, queue_.calls());
  msg::Signer forger("robot_1", testing::testKey(9));
  deliver(inbox, keyframe(2), forger);
  EXPECT_TRUE(queue_.keyframes.empty());
  const InboxStats s = inbox.stats();
  EXPECT_EQ(s.messages_rejected, 1u);
  ASSERT_EQ(s.rejects.size(), 1u);
  EXPECT_EQ(s.rejects[0].robot_id, "robot_1");
  EXPECT_EQ(s.rejects[0].reason, "bad_signature");
}

TEST_F(InboxTest, RobotsNotServedGetOneUnsignedNoticeSayingWhyNotEveryMessage) {
  std::vector<std::pair<std::string, msg::ServerStatus>> sent;
  auto sink = [&sent](const std::string& robot, const msg::ServerStatus& notice) {
    sent.emplace_back(robot, notice);
  };
  InboxConfig config;
  config.robots = {"robot_1", "robot_2"};
  Inbox inbox(config, keys_, registry_, queue_.calls());
  inbox.setNoticeSink(sink);
  msg::Signer unlisted("robot_9", testing::testKey(9));  // neither listed nor keyed
  for (int id = 1; id <= 3; ++id) deliver(inbox, keyframe(id, "robot_9"), unlisted);
  ASSERT_EQ(sent.size(), 1u) << "rate-limited per robot (one per second)";
  EXPECT_EQ(sent[0].first, "robot_9");
  ASSERT_EQ(sent[0].second.rejects.size(), 1u);
  EXPECT_EQ(sent[0].second.rejects[0].reason, "unknown_robot") << "not in server.robots says more than no key";
  msg::Signer keyless("robot_2", testing::testKey(2));  // listed, but the server holds no key for it
  deliver(inbox, keyframe(1, "robot_2"), keyless);
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_EQ(sent[1].first, "robot_2");
  EXPECT_EQ(sent[1].second.rejects[0].reason, "unknown_sender");
  deliver(inbox, keyframe(1), signer_);  // served: no notice
  msg::Signer forger("robot_1", testing::testKey(7));  // served, wrong key: its status says so, not a notice
  deliver(inbox, keyframe(2), forger);
  EXPECT_EQ(sent.size(), 2u);
  EXPECT_EQ(inbox.stats().refusal_notices_sent, 2u);
  EXPECT_EQ(queue_.keyframes.size(), 1u);
}

}  // namespace
}  // namespace rgbdmap
