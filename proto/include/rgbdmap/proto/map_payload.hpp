#pragma once
// The octree bytes of a MapUpdate: compressed with zstd (one frame that declares its size) or stored.
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::msg {

/// Fills update->compression, raw_size and data from the octree bytes (at most kMaxMapBytes).
Status setMapBytes(const Bytes& octree, MapCompression compression, MapUpdate* update, int zstd_level = 3);
/// The octree bytes; checks that the decompressed length is exactly raw_size.
Result<Bytes> mapBytes(const MapUpdate& update);

}  // namespace rgbdmap::msg
