// Chunked keyframe transfers: split (proto/chunking.hpp) and reassembly (server ChunkReassembly) under loss,
// duplicates, reordering, contradicting chunks and the per-robot bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "rgbdmap/intake/chunk_reassembly.hpp"
#include "rgbdmap/proto/chunking.hpp"
#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap {
namespace {

using Clock = ChunkReassembly::Clock;
using Outcome = ChunkReassembly::Outcome;

msg::Bytes envelopeBytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  msg::Bytes b(n);
  for (auto& x : b) x = static_cast<uint8_t>(rng());
  return b;
}

std::vector<msg::KeyframeChunk> split(const msg::Bytes& envelope, int chunk_bytes, int keyframe_id,
                                      int64_t transfer_id) {
  std::vector<msg::KeyframeChunk> out;
  const int count = msg::chunkCount(envelope.size(), chunk_bytes);
  for (int i = 0; i < count; ++i) {
    msg::KeyframeChunk c =
        msg::makeChunk(envelope, chunk_bytes, i, "robot_1", keyframe_id, transfer_id).value();
    c.header = msg::Header{msg::kSchemaVersion, "robot_1", 1, i, 1};
    EXPECT_TRUE(msg::validate(c)) << i;
    out.push_back(std::move(c));
  }
  return out;
}

TEST(ChunkReassembly, SplitCoversTheEnvelopeExactly) {
  EXPECT_EQ(msg::chunkCount(2400, 1200), 2);
  EXPECT_EQ(msg::chunkCount(2401, 1200), 3);
  EXPECT_EQ(msg::chunkCount(0, 1200), 0);
  EXPECT_EQ(msg::chunkCount(100, 10), 0);
  const msg::Bytes env = envelopeBytes(5000, 1);
  const auto chunks = split(env, 1200, 3, 9);
  ASSERT_EQ(chunks.size(), 5u);
  EXPECT_EQ(chunks.back().data.size(), 200u);
  EXPECT_FALSE(msg::makeChunk(env, 1200, 5, "robot_1", 3, 9));
}

TEST(ChunkReassembly, LossDuplicatesAndReorderingStillReassembleOnce) {
  std::mt19937 rng(5);
  const msg::Bytes env = envelopeBytes(140000, 2);
  auto chunks = split(env, 1200, 7, 100);
  ChunkReassembly r;
  const auto now = Clock::now();
  // First pass: ~10 % lost, the rest shuffled, some twice.
  std::shuffle(chunks.begin(), chunks.end(), rng);
  std::vector<int> lost;
  msg::Bytes out;
  for (const auto& c : chunks) {
    if (rng() % 10 == 0) {
      lost.push_back(c.chunk_index);
      continue;
    }
    EXPECT_EQ(r.add("robot_1", c, now, &out), Outcome::kStored);
    if (rng() % 5 == 0) {
      EXPECT_EQ(r.add("robot_1", c, now, &out), Outcome::kDuplicate);
    }
  }
  ASSERT_FALSE(lost.empty());
  const msg::Bytes bitmap = r.receivedBitmap("robot_1", 100).value();
  int missing = 0;
  for (int i = 0; i < static_cast<int>(chunks.size()); ++i) missing += msg::chunkReceived(bitmap, i) ? 0 : 1;
  EXPECT_EQ(missing, static_cast<int>(lost.size()));
  // Resend only the missing ones.
  Outcome last = Outcome::kStored;
  for (int index : lost) {
    const auto it =
        std::find_if(chunks.begin(), chunks.end(), [&](const auto& c) { return c.chunk_index == index; });
    last = r.add("robot_1", *it, now, &out);
  }
  EXPECT_EQ(last, Outcome::kComplete);
  EXPECT_EQ(out, env);
  EXPECT_EQ(r.transfersInProgress(), 0u);
  EXPECT_EQ(r.bytesInProgress(), 0u);
  // A late duplicate does not start the transfer again; its bitmap says "all received".
  EXPECT_EQ(r.add("robot_1", chunks.front(), now, &out), Outcome::kDuplicate);
  EXPECT_EQ(r.transfersInProgress(), 0u);
  const msg::Bytes done = r.receivedBitmap("robot_1", 100).value();
  for (int i = 0; i < static_cast<int>(chunks.size()); ++i) EXPECT_TRUE(msg::chunkReceived(done, i));
}

TEST(ChunkReassembly, ContradictingChunksAreRefused) {
  ChunkReassembly r;
  const auto now = Clock::now();
  msg::Bytes out;
  const auto a = split(envelopeBytes(5000, 3), 1200, 1, 50);
  const auto b = split(envelopeBytes(7000, 4), 1000, 2, 50);  // same transfer id, other layout
  EXPECT_EQ(r.add("robot_1", a[0], now, &out), Outcome::kStored);
  EXPECT_EQ(r.add("robot_1", b[1], now, &out), Outcome::kRefused);
  EXPECT_EQ(r.stats().refused, 1u);
  // Another robot's transfer with the same id is separate.
  EXPECT_EQ(r.add("robot_2", b[1], now, &out), Outcome::kStored);
}

TEST(ChunkReassembly, ARestartedRobotsTransferIdsStartAfresh) {
  ChunkReassembly r;
  const auto now = Clock::now();
  msg::Bytes out;
  auto first = split(envelopeBytes(3000, 1), 1200, 1, 0);
  for (const auto& c : first) r.add("robot_1", c, now, &out);
  auto pending = split(envelopeBytes(9000, 2), 1200, 2, 1);
  EXPECT_EQ(r.add("robot_1", pending[0], now, &out), Outcome::kStored);
  // Same session, transfer id 0 again with another layout: refused, not "all received".
  auto other = split(envelopeBytes(5000, 3), 1200, 1, 0);
  EXPECT_EQ(r.add("robot_1", other[0], now, &out), Outcome::kRefused);
  // A new session (restart): ids 0 and 1 are new transfers.
  for (auto& c : other) c.header.session = 2;
  auto restarted = split(envelopeBytes(7000, 4), 1200, 2, 1);
  for (auto& c : restarted) c.header.session = 2;
  EXPECT_EQ(r.add("robot_1", other[0], now, &out), Outcome::kStored);
  EXPECT_EQ(r.add("robot_1", restarted[0], now, &out), Outcome::kStored);
  EXPECT_EQ(r.transfersInProgress(), 2u);
  EXPECT_EQ(r.bytesInProgress(), 12000u);
}

TEST(ChunkReassembly, BoundsPerRobotEvictOldestAndTimeOut) {
  ChunkReassemblyOptions options;
  options.max_transfers_per_robot = 3;
  options.max_bytes_per_robot = 400000;
  options.timeout_s = 2.0;
  ChunkReassembly r(options);
  auto now = Clock::now();
  msg::Bytes out;
  for (int64_t t = 0; t < 50; ++t) {  // a robot that starts transfers and never finishes them
    const auto chunks = split(envelopeBytes(150000, static_cast<uint32_t>(t)), 1200, static_cast<int>(t), t);
    EXPECT_EQ(r.add("flood", chunks[0], now, &out), Outcome::kStored);
    now += std::chrono::milliseconds(1);
    EXPECT_LE(r.transfersInProgress(), 2u);  // 3 x 150 KB > 400 KB
    EXPECT_LE(r.bytesInProgress(), options.max_bytes_per_robot);
  }
  EXPECT_EQ(r.stats().evicted, 48u);
  // Larger than the per-robot budget: refused outright.
  const auto huge = split(envelopeBytes(500000, 9), 50000, 99, 999);
  EXPECT_EQ(r.add("flood", huge[0], now, &out), Outcome::kRefused);
  // Another robot is not affected by the flood.
  const auto good = split(envelopeBytes(3000, 10), 1200, 1, 1);
  for (const auto& c : good) r.add("good", c, now, &out);
  EXPECT_EQ(out.size(), 3000u);
  // All robots together: a new transfer beyond max_total_bytes is refused.
  ChunkReassemblyOptions tight = options;
  tight.max_total_bytes = 500000;
  ChunkReassembly shared(tight);
  for (int robot = 0; robot < 10; ++robot) {
    const auto chunks = split(envelopeBytes(150000, 1), 1200, 1, 1);
    const Outcome o = shared.add("robot" + std::to_string(robot), chunks[0], now, &out);
    EXPECT_EQ(o, robot < 3 ? Outcome::kStored : Outcome::kRefused) << robot;
  }
  EXPECT_LE(shared.bytesInProgress(), tight.max_total_bytes);
  // Idle transfers time out.
  r.evictStale(now + std::chrono::seconds(3));
  EXPECT_EQ(r.transfersInProgress(), 0u);
  EXPECT_EQ(r.bytesInProgress(), 0u);
  EXPECT_EQ(r.stats().timed_out, 2u);
}

}  // namespace
}  // namespace rgbdmap
