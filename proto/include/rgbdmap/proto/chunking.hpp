#pragma once
// Splitting a signed keyframe envelope into KeyframeChunk messages (robot side) and reading a ChunkAck's
// bitmap. Reassembly is the server's (server/core/intake/include/rgbdmap/intake/chunk_reassembly.hpp).
#include <cstdint>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::msg {

/// ceil(total / chunk_bytes); 0 when the arguments are out of the KeyframeChunk bounds.
int chunkCount(size_t total_bytes, int chunk_bytes);

/// Chunk `index` of `envelope` (header left for the Signer). Fails when the arguments are out of bounds.
Result<KeyframeChunk> makeChunk(const Bytes& envelope, int chunk_bytes, int index,
                                const std::string& robot_id, int keyframe_id, int64_t transfer_id);

/// True if bit `index` is set in a ChunkAck bitmap (false beyond its end).
inline bool chunkReceived(const Bytes& bitmap, int index) {
  const size_t byte = static_cast<size_t>(index / 8);
  return index >= 0 && byte < bitmap.size() && ((bitmap[byte] >> (index % 8)) & 1u) != 0;
}

}  // namespace rgbdmap::msg
