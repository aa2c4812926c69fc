// Envelope authentication and replay protection.
#include <gtest/gtest.h>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap_lcm/envelope_t.hpp"

namespace rgbdmap::msg {
namespace {

using testing::testKey;
constexpr int64_t kT = 1700000000000000;

bool startsWith(const std::string& s, const std::string& prefix) { return s.rfind(prefix, 0) == 0; }

struct Receiver {
  KeyStore keys;
  ReplayGuard guard;
  RejectCounters counters;
  Receiver() { EXPECT_TRUE(keys.add("robot_1", testKey(1))); }
  Result<OpenedEnvelope> open(const Bytes& b) { return openEnvelope(b, keys, &guard, &counters); }
};

TEST(Envelope, MacIsTheLastFieldAndCoversTheRest) {
  Signer signer("robot_1", testKey(1), 5);
  const Bytes bytes = signer.seal(testing::sampleHeartbeat(), kT).value();
  rgbdmap_lcm::envelope_t e;
  ASSERT_EQ(e.decode(bytes.data(), 0, static_cast<int>(bytes.size())), static_cast<int>(bytes.size()));
  EXPECT_TRUE(std::equal(e.mac, e.mac + 32, bytes.end() - 32));
  EXPECT_EQ(e.header.sender, "robot_1");
  EXPECT_EQ(e.header.session, 5);
  EXPECT_EQ(e.type, static_cast<int>(MessageType::kHeartbeat));
}

TEST(Envelope, ARejectionNotesTheReasonAndTheClaimedSender) {
  Receiver rx;
  RejectNote note;
  Signer wrong_key("robot_1", testKey(2));
  const Bytes bytes = wrong_key.seal(testing::sampleHeartbeat(), kT).value();
  ASSERT_FALSE(openEnvelope(bytes, rx.keys, &rx.guard, &rx.counters, &note));
  EXPECT_EQ(note.reason, RejectReason::kBadSignature);
  EXPECT_EQ(note.claimed_sender, "robot_1");
  note = RejectNote{};
  ASSERT_FALSE(openEnvelope(Bytes(64, 0x11), rx.keys, &rx.guard, nullptr, &note));
  EXPECT_EQ(note.reason, RejectReason::kTruncated);
  EXPECT_EQ(note.claimed_sender, "") << "no header decoded";
  note = RejectNote{};
  Signer right("robot_1", testKey(1));
  ASSERT_TRUE(
      openEnvelope(right.seal(testing::sampleHeartbeat(), kT).value(), rx.keys, &rx.guard, nullptr, &note));
  EXPECT_EQ(note.reason, RejectReason::kCount) << "untouched on success";
}

TEST(Envelope, WrongKeyUnknownSenderInvalidSender) {
  Receiver rx;
  Signer wrong_key("robot_1", testKey(2));
  Result<OpenedEnvelope> r = rx.open(wrong_key.seal(testing::sampleHeartbeat(), kT).value());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), "bad signature");
  EXPECT_EQ(rx.counters.get(RejectReason::kBadSignature), 1u);

  msg::Heartbeat hb = testing::sampleHeartbeat();
  hb.robot_id = "robot_9";
  Signer stranger("robot_9", testKey(1));
  r = rx.open(stranger.seal(hb, kT).value());
  ASSERT_FALSE(r);
  EXPECT_TRUE(startsWith(r.error(), "unknown sender")) << r.error();
  EXPECT_EQ(rx.counters.get(RejectReason::kUnknownSender), 1u);

  Signer unsigned_robot("robot_1", {});
  r = rx.open(unsigned_robot.seal(testing::sampleHeartbeat(), kT).value());
  EXPECT_EQ(r.error(), "bad signature");
  EXPECT_EQ(rx.counters.total(), 3u);
}

TEST(Envelope, ReplayReorderAndWindow) {
  Receiver rx;
  Signer signer("robot_1", testKey(1), 10);
  std::vector<Bytes> sent;
  for (int i = 0; i < 100; ++i) sent.push_back(signer.seal(testing::sampleHeartbeat(), kT + i).value());
  EXPECT_TRUE(rx.open(sent[5]));
  EXPECT_TRUE(rx.open(sent[2]));  // reordered, within the window
  EXPECT_TRUE(rx.open(sent[3]));
  Result<OpenedEnvelope> r = rx.open(sent[2]);
  ASSERT_FALSE(r);
  EXPECT_TRUE(startsWith(r.error(), "replayed seq")) << r.error();
  EXPECT_TRUE(rx.open(sent[90]));
  EXPECT_TRUE(rx.open(sent[27]));   // 90 - 27 = 63 < 64: still in the window
  EXPECT_FALSE(rx.open(sent[26]));  // 64 behind: too old
  EXPECT_FALSE(rx.open(sent[90]));
  EXPECT_TRUE(rx.open(sent[99]));
  EXPECT_EQ(rx.counters.get(RejectReason::kReplayedSeq), 3u);
}

TEST(Envelope, RestartedSenderNewSession) {
  Receiver rx;
  Signer before("robot_1", testKey(1), 100);
  const Bytes old0 = before.seal(testing::sampleHeartbeat(), kT).value();
  const Bytes old1 = before.seal(testing::sampleHeartbeat(), kT).value();
  EXPECT_TRUE(rx.open(old0));
  EXPECT_TRUE(rx.open(old1));
  Signer after("robot_1", testKey(1), 200);  // restarted: seq starts at 0 again
  EXPECT_TRUE(rx.open(after.seal(testing::sampleHeartbeat(), kT).value()));
  Result<OpenedEnvelope> r = rx.open(old0);  // the old session is over
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), "replayed seq: older session");
}

TEST(Envelope, OpenMode) {
  KeyStore keys = KeyStore::openMode();
  ASSERT_TRUE(keys.add("robot_1", testKey(1)));
  ReplayGuard guard;
  Signer anonymous("robot_7", {});
  msg::Heartbeat hb = testing::sampleHeartbeat();
  hb.robot_id = "robot_7";
  Result<OpenedEnvelope> r = openEnvelope(anonymous.seal(hb, kT).value(), keys, &guard);
  ASSERT_TRUE(r) << r.error();
  EXPECT_FALSE(r->authenticated);
  EXPECT_TRUE(decodeMessage<Heartbeat>(*r));
  Signer forger("robot_1", {});  // a sender with a key must still sign, even in open mode
  EXPECT_EQ(openEnvelope(forger.seal(testing::sampleHeartbeat(), kT).value(), keys, &guard).error(),
            "bad signature");
}

TEST(Envelope, WrongVersionTypeAndHeaderMismatch) {
  Receiver rx;
  Header h{kSchemaVersion + 1, "robot_1", 1, 0, kT};
  Bytes payload;
  Heartbeat hb = testing::sampleHeartbeat();
  hb.header = Header{kSchemaVersion, "robot_1", 1, 0, kT};
  payload = encodePayload(hb).value();
  EXPECT_FALSE(encodeEnvelope(MessageType::kHeartbeat, h, payload, testKey(1)));  // the encoder refuses too
  h.schema_version = kSchemaVersion;
  h.seq = 1;  // envelope header differs from the message's
  Result<OpenedEnvelope> opened =
      rx.open(encodeEnvelope(MessageType::kHeartbeat, h, payload, testKey(1)).value());
  ASSERT_TRUE(opened) << opened.error();
  EXPECT_EQ(decodeMessage<Heartbeat>(*opened, &rx.counters).error(), "header mismatch");
  EXPECT_TRUE(startsWith(decodeMessage<Keyframe>(*opened, &rx.counters).error(), "wrong type"));
  h.seq = 2;
  opened = rx.open(encodeEnvelope(MessageType::kKeyframe, h, payload, testKey(1)).value());
  ASSERT_TRUE(opened);
  EXPECT_TRUE(startsWith(decodeMessage<Keyframe>(*opened, &rx.counters).error(), "invalid content"));
  EXPECT_EQ(rx.counters.get(RejectReason::kHeaderMismatch), 1u);
  EXPECT_EQ(rx.counters.get(RejectReason::kWrongType), 1u);
  EXPECT_EQ(rx.counters.get(RejectReason::kInvalidContent), 1u);
}

TEST(Envelope, ForgedVersionAndTypeInSignedBytes) {
  Receiver rx;
  Signer signer("robot_1", testKey(1));
  Bytes bytes = signer.seal(testing::sampleHeartbeat(), kT).value();
  // header_t is first after the 8-byte type hash of envelope_t... and of header_t (nested structs carry
  // none).
  bytes[8] ^= 0x01;  // schema_version high byte
  EXPECT_TRUE(startsWith(rx.open(bytes).error(), "wrong schema version"));
  EXPECT_TRUE(startsWith(rx.open(Bytes(bytes.begin(), bytes.begin() + 20)).error(), "truncated"));
  EXPECT_TRUE(startsWith(rx.open(Bytes(bytes.size() - 1, 0)).error(), "truncated"));
}

TEST(Envelope, KeysFromHex) {
  EXPECT_EQ(parseHexKey("000102030405060708090a0b0c0d0e0fA0").value().size(), 17u);
  EXPECT_FALSE(parseHexKey("0001"));
  EXPECT_FALSE(parseHexKey("000102030405060708090a0b0c0d0e0g"));
  KeyStore keys;
  EXPECT_FALSE(keys.add("robot 1", testKey(1)));
  EXPECT_FALSE(keys.add("robot_1", Bytes(8, 1)));
}

}  // namespace
}  // namespace rgbdmap::msg

namespace rgbdmap::msg {
namespace {

TEST(ReplayGuardLimits, NewSendersBeyondTheCapAreRefusedNotEvicted) {
  ReplayGuard guard(2);
  auto header = [](const std::string& sender, int64_t seq) {
    return Header{kSchemaVersion, sender, 1, seq, 0};
  };
  EXPECT_TRUE(guard.check(header("a", 0)));
  EXPECT_TRUE(guard.check(header("b", 0)));
  const Status third = guard.check(header("c", 0));
  ASSERT_FALSE(third);
  EXPECT_EQ(third.error(), "too many senders");
  EXPECT_FALSE(guard.check(header("a", 0))) << "a's replay must still be caught";
  EXPECT_TRUE(guard.check(header("a", 1)));
}

TEST(RejectCountersLog, CountsEveryRejectionButLogsAtTheRateLimit) {
  std::vector<std::string> lines;
  log::setSink([&](log::Level, const std::string& m) { lines.push_back(m); });
  RejectCounters counters(1.0);
  for (int i = 0; i < 100; ++i) counters.add(RejectReason::kBadSignature, "robot_7");
  log::setSink(nullptr);
  EXPECT_EQ(counters.get(RejectReason::kBadSignature), 100u);
  EXPECT_EQ(counters.total(), 100u);
  ASSERT_EQ(lines.size(), 1u) << "one line per second at most";
  EXPECT_NE(lines[0].find("bad signature (robot_7)"), std::string::npos) << lines[0];
}

}  // namespace
}  // namespace rgbdmap::msg
