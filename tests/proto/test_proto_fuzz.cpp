// Seeded corruption: thousands of mutations of valid signed envelopes of every type. Without a valid
// signature every mutant must be rejected with a reason; re-signed mutants (a sender with the key that
// sends garbage) must decode to an error or to a message that passes validation. Never a crash; the
// sanitizer pass of deploy/test.sh runs this too.
#include <gtest/gtest.h>

#include <random>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap::msg {
namespace {

using testing::testKey;

template <typename T>
Status decodeAs(const OpenedEnvelope& e, RejectCounters* counters) {
  Result<T> m = decodeMessage<T>(e, counters);
  if (!m) return Status::failure(m.error());
  return validate(*m);  // whatever decodes must be valid
}

/// Decodes an opened envelope as its type; ok only for a valid message.
Status decodeAny(const OpenedEnvelope& e, RejectCounters* c) {
  switch (e.type) {
    case MessageType::kHello:
      return decodeAs<Hello>(e, c);
    case MessageType::kHeartbeat:
      return decodeAs<Heartbeat>(e, c);
    case MessageType::kKeyframe:
      return decodeAs<Keyframe>(e, c);
    case MessageType::kKeyframeAck:
      return decodeAs<KeyframeAck>(e, c);
    case MessageType::kPoseCorrections:
      return decodeAs<PoseCorrections>(e, c);
    case MessageType::kOccupancySlice:
      return decodeAs<OccupancySlice>(e, c);
    case MessageType::kMapUpdate:
      return decodeAs<MapUpdate>(e, c);
    case MessageType::kVelocityCommand:
      return decodeAs<VelocityCommand>(e, c);
    case MessageType::kServerStatus:
      return decodeAs<ServerStatus>(e, c);
    case MessageType::kKeyframeChunk:
      return decodeAs<KeyframeChunk>(e, c);
    case MessageType::kChunkAck:
      return decodeAs<ChunkAck>(e, c);
    case MessageType::kLoopEdges:
      return decodeAs<LoopEdges>(e, c);
    case MessageType::kRobotPose:
      return decodeAs<RobotPose>(e, c);
    case MessageType::kLinkStatus:
      return decodeAs<LinkStatus>(e, c);
  }
  return Status::failure("unknown type");
}

class ProtoFuzz : public ::testing::Test {
 protected:
  ProtoFuzz() : robot_("robot_1", testKey(1), 1000), server_(kServerId, testKey(1), 1000) {
    EXPECT_TRUE(keys_.add("robot_1", testKey(1)));
    EXPECT_TRUE(keys_.add(kServerId, testKey(1)));
    EXPECT_TRUE(keys_.add("robot_2", testKey(2)));
    samples_ = testing::sampleEnvelopes(&robot_, &server_);
  }

  /// Opens with a fresh replay guard (so replay is not what rejects it) and decodes.
  Status openAndDecode(const Bytes& bytes) {
    ReplayGuard guard;
    Result<OpenedEnvelope> e = openEnvelope(bytes, keys_, &guard, &counters_);
    if (!e) return Status::failure(e.error());
    return decodeAny(*e, &counters_);
  }

  Bytes mutate(const Bytes& in, std::mt19937& rng) {
    Bytes b = in;
    auto pick = [&](size_t n) { return std::uniform_int_distribution<size_t>(0, n - 1)(rng); };
    switch (pick(5)) {
      case 0:  // bit flips
        for (size_t i = 0, n = 1 + pick(4); i < n; ++i)
          b[pick(b.size())] ^= static_cast<uint8_t>(1u << pick(8));
        break;
      case 1:
        b.resize(pick(b.size()));
        break;  // truncation
      case 2:   // extension
        for (size_t i = 0, n = 1 + pick(64); i < n; ++i) b.push_back(static_cast<uint8_t>(rng()));
        break;
      case 3: {  // forged length: a big-endian int32 anywhere
        const uint32_t values[] = {0, 1, 0x7fffffff, 0x80000000, 0xffffffff, static_cast<uint32_t>(rng())};
        const size_t at = pick(b.size() - 4);
        const uint32_t v = values[pick(6)];
        for (int i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>(v >> (24 - 8 * i));
        break;
      }
      default:
        b[pick(b.size())] = static_cast<uint8_t>(rng());
        break;  // byte overwrite
    }
    return b;
  }

  Signer robot_, server_;
  KeyStore keys_;
  RejectCounters counters_;
  std::vector<Bytes> samples_;
};

TEST_F(ProtoFuzz, ValidSamplesOpen) {
  ASSERT_EQ(samples_.size(), static_cast<size_t>(kNumMessageTypes));
  for (const Bytes& b : samples_) EXPECT_TRUE(openAndDecode(b)) << openAndDecode(b).error();
}

TEST_F(ProtoFuzz, UnsignedMutationsAreAllRejected) {
  std::mt19937 rng(20240501);
  int rejected = 0;
  for (int round = 0; round < 500; ++round) {
    for (const Bytes& sample : samples_) {
      const Bytes b = mutate(sample, rng);
      if (b == sample) continue;
      const Status s = openAndDecode(b);
      ASSERT_FALSE(s) << "mutant accepted in round " << round;
      ASSERT_FALSE(s.error().empty());
      ++rejected;
    }
  }
  EXPECT_GT(rejected, 4000);
  EXPECT_EQ(counters_.total(), static_cast<uint64_t>(rejected));
  EXPECT_GT(counters_.get(RejectReason::kBadSignature), 0u);
  EXPECT_GT(counters_.get(RejectReason::kTruncated), 0u);
  EXPECT_GT(counters_.get(RejectReason::kMalformed), 0u);
}

TEST_F(ProtoFuzz, ForgedHeadersAreRejected) {
  std::mt19937 rng(7);
  for (int round = 0; round < 50; ++round) {
    for (const Bytes& sample : samples_) {
      ReplayGuard guard;
      OpenedEnvelope e = openEnvelope(sample, keys_, &guard).value();
      Header h = e.header;
      switch (round % 5) {
        case 0:
          h.schema_version = static_cast<int>(rng() % 100) + kSchemaVersion + 1;
          break;
        case 1:
          h.sender = "robot_2";
          break;  // a robot signing as itself but carrying another's message
        case 2:
          h.seq += 1 + rng() % 1000;
          break;
        case 3:
          h.session += 1;
          break;
        default:
          h.utime += 1;
          break;
      }
      // Signed correctly with the claimed sender's key, or the encoder refuses (wrong version).
      const Bytes& key = *keys_.find(h.sender);
      Result<Bytes> forged = encodeEnvelope(e.type, h, e.payload, key);
      if (!forged) continue;
      const Status s = openAndDecode(*forged);
      ASSERT_FALSE(s) << "forged header accepted";
      // Unsigned: the original key over a changed header no longer matches.
      Bytes resigned = forged.value();
      std::copy(sample.end() - 32, sample.end(), resigned.end() - 32);
      EXPECT_FALSE(openAndDecode(resigned));
    }
  }
  EXPECT_GT(counters_.get(RejectReason::kHeaderMismatch), 0u);
}

TEST_F(ProtoFuzz, ResignedPayloadMutationsDecodeToErrorsOrValidMessages) {
  std::mt19937 rng(99);
  int errors = 0, valid = 0;
  for (int round = 0; round < 300; ++round) {
    for (const Bytes& sample : samples_) {
      ReplayGuard guard;
      OpenedEnvelope e = openEnvelope(sample, keys_, &guard).value();
      if (e.payload.size() < 8) continue;
      const Bytes payload = mutate(e.payload, rng);
      Result<Bytes> resigned = encodeEnvelope(e.type, e.header, payload, *keys_.find(e.header.sender));
      ASSERT_TRUE(resigned) << resigned.error();
      const Status s = openAndDecode(*resigned);
      if (s) {
        ++valid;
      } else {
        ASSERT_FALSE(s.error().empty());
        ++errors;
      }
    }
  }
  EXPECT_GT(errors, 1500);  // most mutants are caught; the rest are (different) valid messages
  EXPECT_EQ(errors + valid, 300 * kNumMessageTypes);
}

}  // namespace
}  // namespace rgbdmap::msg

#include <sys/resource.h>

namespace rgbdmap::msg {
namespace {

long peakRssMb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss / 1024;
}

TEST(ProtoAllocation, ForgedArrayCountCannotAmplifyAllocation) {
  // A PoseCorrections whose keyframe count is forged to 16M and padded with 16 MB of zeros: the count fits
  // the bytes, but 16M in-memory poses would take about 1 GB. The decoder must refuse before allocating.
  PoseCorrections m;
  m.header.sender = kServerId;
  m.robot_id = "robot_1";
  Bytes bytes = encodePayload(m).value();
  const size_t filler = 16u << 20;
  const auto n = static_cast<uint32_t>(filler);
  const size_t at = bytes.size() - 4;  // num_keyframes is the last field of an empty message
  for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<uint8_t>(n >> (24 - 8 * i));
  bytes.resize(bytes.size() + filler, 0);
  const long before = peakRssMb();
  const auto decoded = decodePayload<PoseCorrections>(bytes);
  EXPECT_FALSE(decoded);
  EXPECT_LT(peakRssMb() - before, 200) << "peak RSS grew while rejecting the forged count";
}

}  // namespace
}  // namespace rgbdmap::msg
