// Wire <-> internal and validation for the chunked keyframe transfer: KeyframeChunk, ChunkAck.
#include <algorithm>

#include "convert_common.hpp"
#include "rgbdmap/proto/chunking.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap_lcm/chunk_ack_t.hpp"
#include "rgbdmap_lcm/keyframe_chunk_t.hpp"

namespace rgbdmap::msg {
namespace {

using detail::fromWire;
using detail::toWire;

Status chunkFailure(const char* reason) { return Status::failure(reason); }

rgbdmap_lcm::keyframe_chunk_t toWireChunk(const KeyframeChunk& m) {
  rgbdmap_lcm::keyframe_chunk_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.transfer_id = m.transfer_id;
  w.keyframe_id = m.keyframe_id;
  w.chunk_index = m.chunk_index;
  w.chunk_count = m.chunk_count;
  w.chunk_bytes = m.chunk_bytes;
  w.total_bytes = m.total_bytes;
  w.last_of_burst = m.last_of_burst;
  w.data_size = detail::count(m.data);
  w.data.assign(m.data.begin(), m.data.end());
  return w;
}

Result<KeyframeChunk> fromWireChunk(const rgbdmap_lcm::keyframe_chunk_t& w) {
  KeyframeChunk m;
  m.header = fromWire(w.header);
  m.robot_id = w.robot_id;
  m.transfer_id = w.transfer_id;
  m.keyframe_id = w.keyframe_id;
  m.chunk_index = w.chunk_index;
  m.chunk_count = w.chunk_count;
  m.chunk_bytes = w.chunk_bytes;
  m.total_bytes = w.total_bytes;
  m.last_of_burst = w.last_of_burst != 0;
  m.data.assign(w.data.begin(), w.data.end());
  return m;
}

rgbdmap_lcm::chunk_ack_t toWireChunkAck(const ChunkAck& m) {
  rgbdmap_lcm::chunk_ack_t w;
  w.header = toWire(m.header);
  w.robot_id = m.robot_id;
  w.transfer_id = m.transfer_id;
  w.keyframe_id = m.keyframe_id;
  w.chunk_count = m.chunk_count;
  w.received_size = detail::count(m.received);
  w.received.assign(m.received.begin(), m.received.end());
  return w;
}

Result<ChunkAck> fromWireChunkAck(const rgbdmap_lcm::chunk_ack_t& w) {
  ChunkAck m;
  m.header = fromWire(w.header);
  m.robot_id = w.robot_id;
  m.transfer_id = w.transfer_id;
  m.keyframe_id = w.keyframe_id;
  m.chunk_count = w.chunk_count;
  m.received.assign(w.received.begin(), w.received.end());
  return m;
}

}  // namespace

Status validate(const KeyframeChunk& m) {
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return chunkFailure("invalid robot id");
  if (m.header.sender != m.robot_id) return chunkFailure("sender is not the robot");
  if (m.transfer_id < 0 || m.keyframe_id < 0) return chunkFailure("negative id");
  if (m.chunk_bytes < kMinChunkBytes || m.chunk_bytes > kMaxChunkBytes)
    return chunkFailure("chunk size out of range");
  if (m.total_bytes <= 0 || m.total_bytes > kMaxChunkedBytes) return chunkFailure("total size out of range");
  const int64_t count = (int64_t{m.total_bytes} + m.chunk_bytes - 1) / m.chunk_bytes;
  if (m.chunk_count != count || m.chunk_count > kMaxChunkCount)
    return chunkFailure("chunk count != total / chunk size");
  if (m.chunk_index < 0 || m.chunk_index >= m.chunk_count) return chunkFailure("chunk index out of range");
  const int64_t offset = int64_t{m.chunk_index} * m.chunk_bytes;
  const int64_t expected = std::min<int64_t>(m.chunk_bytes, m.total_bytes - offset);
  if (static_cast<int64_t>(m.data.size()) != expected)
    return chunkFailure("chunk data size does not match its index");
  return Status::success();
}

Status validate(const ChunkAck& m) {
  if (Status s = validate(m.header); !s) return s;
  if (!isRobotId(m.robot_id)) return chunkFailure("invalid robot id");
  if (m.header.sender != kServerId) return chunkFailure("sender is not the server");
  if (m.transfer_id < 0 || m.keyframe_id < 0) return chunkFailure("negative id");
  if (m.chunk_count < 1 || m.chunk_count > kMaxChunkCount) return chunkFailure("chunk count out of range");
  if (m.received.size() != static_cast<size_t>((m.chunk_count + 7) / 8))
    return chunkFailure("bitmap size != count");
  return Status::success();
}

int chunkCount(size_t total_bytes, int chunk_bytes) {
  if (chunk_bytes < kMinChunkBytes || chunk_bytes > kMaxChunkBytes || total_bytes == 0 ||
      total_bytes > static_cast<size_t>(kMaxChunkedBytes))
    return 0;
  return static_cast<int>((total_bytes + static_cast<size_t>(chunk_bytes) - 1) /
                          static_cast<size_t>(chunk_bytes));
}

Result<KeyframeChunk> makeChunk(const Bytes& envelope, int chunk_bytes, int index,
                                const std::string& robot_id, int keyframe_id, int64_t transfer_id) {
  const int count = chunkCount(envelope.size(), chunk_bytes);
  if (count == 0 || index < 0 || index >= count)
    return Result<KeyframeChunk>::failure("chunk arguments out of range");
  KeyframeChunk c;
  c.robot_id = robot_id;
  c.transfer_id = transfer_id;
  c.keyframe_id = keyframe_id;
  c.chunk_index = index;
  c.chunk_count = count;
  c.chunk_bytes = chunk_bytes;
  c.total_bytes = static_cast<int>(envelope.size());
  const size_t begin = static_cast<size_t>(index) * static_cast<size_t>(chunk_bytes);
  const size_t end = std::min(envelope.size(), begin + static_cast<size_t>(chunk_bytes));
  c.data.assign(envelope.begin() + static_cast<std::ptrdiff_t>(begin),
                envelope.begin() + static_cast<std::ptrdiff_t>(end));
  return c;
}

RGBDMAP_PROTO_CODEC(KeyframeChunk, toWireChunk, fromWireChunk)
RGBDMAP_PROTO_CODEC(ChunkAck, toWireChunkAck, fromWireChunkAck)

}  // namespace rgbdmap::msg
