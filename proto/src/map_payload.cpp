// zstd compression of a MapUpdate's octree bytes, with the decompressed length checked before allocating.
#include <zstd.h>

#include "rgbdmap/proto/map_payload.hpp"

namespace rgbdmap::msg {

Status setMapBytes(const Bytes& octree, MapCompression compression, MapUpdate* update, int zstd_level) {
  if (octree.size() > static_cast<size_t>(kMaxMapBytes)) return Status::failure("map too large");
  update->compression = compression;
  update->raw_size = static_cast<int>(octree.size());
  if (compression == MapCompression::kNone) {
    update->data = octree;
    return Status::success();
  }
  Bytes out(ZSTD_compressBound(octree.size()));
  const size_t n = ZSTD_compress(out.data(), out.size(), octree.data(), octree.size(), zstd_level);
  if (ZSTD_isError(n)) return Status::failure(std::string("zstd: ") + ZSTD_getErrorName(n));
  out.resize(n);
  update->data = std::move(out);
  return Status::success();
}

Result<Bytes> mapBytes(const MapUpdate& update) {
  using R = Result<Bytes>;
  if (update.raw_size < 0 || update.raw_size > kMaxMapBytes) return R::failure("map size out of range");
  if (update.compression == MapCompression::kNone) {
    if (update.data.size() != static_cast<size_t>(update.raw_size))
      return R::failure("map data size != raw size");
    return update.data;
  }
  const unsigned long long declared = ZSTD_getFrameContentSize(update.data.data(), update.data.size());
  if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN)
    return R::failure("map data is not a zstd frame with a content size");
  if (declared != static_cast<unsigned long long>(update.raw_size))
    return R::failure("decompressed length != raw size");
  if (ZSTD_findFrameCompressedSize(update.data.data(), update.data.size()) != update.data.size())
    return R::failure("map data is not exactly one zstd frame");
  Bytes out(static_cast<size_t>(update.raw_size));
  const size_t n = ZSTD_decompress(out.data(), out.size(), update.data.data(), update.data.size());
  if (ZSTD_isError(n)) return R::failure(std::string("zstd: ") + ZSTD_getErrorName(n));
  if (n != out.size()) return R::failure("decompressed length != raw size");
  return out;
}

}  // namespace rgbdmap::msg
