// KeyframeChunk / ChunkAck: round trip, and every inconsistent or out-of-range chunk header is refused on
// encode and on decode (crafted wire bytes), so the server's reassembly only ever sees consistent chunks.
#include <gtest/gtest.h>

#include <functional>

#include "proto/proto_test_util.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/validate.hpp"
#include "rgbdmap_lcm/keyframe_chunk_t.hpp"

namespace rgbdmap::msg {
namespace {

Header chunkTestHeader() { return Header{kSchemaVersion, "robot_1", 1, 0, 1}; }

TEST(ProtoChunk, RoundTripThroughSignedEnvelope) {
  Signer robot("robot_1", testing::testKey(1), 5);
  KeyStore keys;
  ASSERT_TRUE(keys.add("robot_1", testing::testKey(1)));
  ReplayGuard guard;
  const Bytes bytes = robot.seal(testing::sampleChunk(), 1).value();
  Result<OpenedEnvelope> opened = openEnvelope(bytes, keys, &guard);
  ASSERT_TRUE(opened) << opened.error();
  Result<KeyframeChunk> c = decodeMessage<KeyframeChunk>(*opened);
  ASSERT_TRUE(c) << c.error();
  EXPECT_EQ(c->transfer_id, 77);
  EXPECT_EQ(c->chunk_index, 2);
  EXPECT_TRUE(c->last_of_burst);
  EXPECT_EQ(c->data, testing::sampleChunk().data);
  EXPECT_LT(bytes.size(), 1400u) << "a 1,200-byte chunk must fit one Ethernet datagram with its envelope";
}

TEST(ProtoChunk, DefaultChunkFitsOneEthernetDatagramForTheLongestRobotId) {
  const std::string robot(kMaxIdLength, 'r');
  Signer signer(robot, testing::testKey(1), 1732500000000000);
  KeyframeChunk c = testing::sampleChunk();
  c.robot_id = robot;
  c.chunk_index = 0;
  c.chunk_bytes = 1100;
  c.chunk_count = 3;
  c.data.assign(1100, 0x11);
  c.transfer_id = c.keyframe_id = 2000000000;
  const Result<Bytes> sealed = signer.seal(c, 1732500000000000);
  ASSERT_TRUE(sealed) << sealed.error();
  const Bytes& bytes = *sealed;
  // The default chunk_bytes (resolveChunkBytes). LCM: 8-byte short-message header (or 20-byte fragment
  // header) + channel name + NUL + payload; one datagram at MTU 1500 carries 1472 bytes of UDP payload.
  const size_t channel = std::string("rgbdmap/" + robot + "/keyframe_chunk").size() + 1;
  EXPECT_LE(bytes.size() + 20 + channel, 1472u) << bytes.size();
}

TEST(ProtoChunk, InconsistentHeadersAreRefused) {
  const std::vector<std::pair<const char*, std::function<void(KeyframeChunk&)>>> cases = {
      {"index past count", [](KeyframeChunk& c) { c.chunk_index = 3; }},
      {"negative index", [](KeyframeChunk& c) { c.chunk_index = -1; }},
      {"count too small", [](KeyframeChunk& c) { c.chunk_count = 2; }},
      {"count too large", [](KeyframeChunk& c) { c.chunk_count = 4; }},
      {"total too large", [](KeyframeChunk& c) { c.total_bytes = kMaxChunkedBytes + 1; }},
      {"total zero", [](KeyframeChunk& c) { c.total_bytes = 0; }},
      {"chunk too small", [](KeyframeChunk& c) { c.chunk_bytes = 10; }},
      {"chunk too large", [](KeyframeChunk& c) { c.chunk_bytes = kMaxChunkBytes + 1; }},
      {"short data", [](KeyframeChunk& c) { c.data.pop_back(); }},
      {"long data", [](KeyframeChunk& c) { c.data.push_back(0); }},
      {"middle chunk short", [](KeyframeChunk& c) { c.chunk_index = 1; }},
      {"negative transfer", [](KeyframeChunk& c) { c.transfer_id = -1; }},
      {"negative keyframe", [](KeyframeChunk& c) { c.keyframe_id = -1; }},
      {"other robot", [](KeyframeChunk& c) { c.robot_id = "robot_2"; }},
  };
  for (const auto& [name, mutate] : cases) {
    KeyframeChunk c = testing::sampleChunk();
    c.header = chunkTestHeader();
    ASSERT_TRUE(validate(c)) << name;
    mutate(c);
    EXPECT_FALSE(validate(c)) << name;
    EXPECT_FALSE(encodePayload(c)) << name;
    // The same fields on the wire (bypassing the encoder's check) fail to decode.
    rgbdmap_lcm::keyframe_chunk_t w;
    KeyframeChunk valid = testing::sampleChunk();
    valid.header = chunkTestHeader();
    const Bytes b = encodePayload(valid).value();
    ASSERT_EQ(w.decode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
    w.robot_id = c.robot_id;
    w.transfer_id = c.transfer_id;
    w.keyframe_id = c.keyframe_id;
    w.chunk_index = c.chunk_index;
    w.chunk_count = c.chunk_count;
    w.chunk_bytes = c.chunk_bytes;
    w.total_bytes = c.total_bytes;
    w.data_size = static_cast<int32_t>(c.data.size());
    w.data.assign(c.data.begin(), c.data.end());
    Bytes crafted(static_cast<size_t>(w.getEncodedSize()));
    w.encode(crafted.data(), 0, static_cast<int>(crafted.size()));
    EXPECT_FALSE(decodePayload<KeyframeChunk>(crafted)) << name;
  }
}

TEST(ProtoChunk, ChunkAckBitmapMustMatchCount) {
  ChunkAck a = testing::sampleChunkAck();
  a.header = Header{kSchemaVersion, kServerId, 1, 0, 1};
  EXPECT_TRUE(validate(a));
  a.received.push_back(0);
  EXPECT_FALSE(validate(a));
  a = testing::sampleChunkAck();
  a.header = Header{kSchemaVersion, kServerId, 1, 0, 1};
  a.chunk_count = 0;
  EXPECT_FALSE(validate(a));
  a = testing::sampleChunkAck();
  a.header = chunkTestHeader();  // only the server reports chunks
  EXPECT_FALSE(validate(a));
}

}  // namespace
}  // namespace rgbdmap::msg
