// Chunk compression: zstd frames (libzstd) and LZ4 frames (liblz4), as the MCAP spec names them.
#include <algorithm>
#include <memory>

#include <lz4frame.h>
#include <zstd.h>

#include "mcap_bytes.hpp"
#include "rgbdmap/mcap/mcap_reader.hpp"

namespace rgbdmap::mcap {

const char* compressionName(Compression c) {
  switch (c) {
    case Compression::kZstd:
      return "zstd";
    case Compression::kLz4:
      return "lz4";
    case Compression::kNone:
      break;
  }
  return "";
}

namespace detail {
namespace {

using Bytes = Result<std::vector<uint8_t>>;

/// The output buffer: starts small and doubles up to `expected` as the decoder fills it.
void grow(std::vector<uint8_t>* out, size_t used, uint64_t expected) {
  if (used < out->size() || out->size() >= expected) return;
  const uint64_t next = std::min<uint64_t>(expected, std::max<uint64_t>(uint64_t{1} << 20, 2 * out->size()));
  out->resize(static_cast<size_t>(next));
}

Bytes unzstd(const uint8_t* data, size_t size, uint64_t expected) {
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> ctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  std::vector<uint8_t> out;
  ZSTD_inBuffer in{data, size, 0};
  size_t used = 0, hint = 1;
  for (;;) {
    grow(&out, used, expected);
    ZSTD_outBuffer o{out.data(), out.size(), used};
    const size_t in_before = in.pos;
    hint = ZSTD_decompressStream(ctx.get(), &o, &in);
    if (ZSTD_isError(hint)) return Bytes::failure(std::string("zstd: ") + ZSTD_getErrorName(hint));
    const bool progress = o.pos != used || in.pos != in_before;
    used = o.pos;
    if ((hint == 0 && in.pos == in.size) || !progress) break;
  }
  if (used != expected || hint != 0 || in.pos != in.size)
    return Bytes::failure("zstd: the chunk does not decompress to its declared " + std::to_string(expected) +
                          " bytes");
  out.resize(used);
  return out;
}

Bytes unlz4(const uint8_t* data, size_t size, uint64_t expected) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION)))
    return Bytes::failure("lz4: no context");
  std::unique_ptr<LZ4F_dctx, size_t (*)(LZ4F_dctx*)> ctx(raw, LZ4F_freeDecompressionContext);
  std::vector<uint8_t> out;
  size_t in_pos = 0, used = 0, hint = 1;
  for (;;) {
    grow(&out, used, expected);
    size_t dst = out.size() - used, src = size - in_pos;
    hint = LZ4F_decompress(ctx.get(), out.data() + used, &dst, data + in_pos, &src, nullptr);
    if (LZ4F_isError(hint)) return Bytes::failure(std::string("lz4: ") + LZ4F_getErrorName(hint));
    used += dst;
    in_pos += src;
    if ((hint == 0 && in_pos == size) || (dst == 0 && src == 0)) break;
  }
  if (used != expected || hint != 0 || in_pos != size)
    return Bytes::failure("lz4: the chunk does not decompress to its declared " + std::to_string(expected) +
                          " bytes");
  out.resize(used);
  return out;
}

}  // namespace

Bytes decompress(const std::string& compression, const uint8_t* data, size_t size, uint64_t expected) {
  if (expected > kMaxChunkBytes)
    return Bytes::failure("a chunk of " + std::to_string(expected) + " bytes (at most " +
                          std::to_string(kMaxChunkBytes) + ")");
  if (compression.empty()) {
    if (size != expected) return Bytes::failure("an uncompressed chunk whose sizes disagree");
    return std::vector<uint8_t>(data, data + size);
  }
  if (expected == 0) return std::vector<uint8_t>{};  // an empty chunk: nothing to read
  if (compression == "zstd") return unzstd(data, size, expected);
  if (compression == "lz4") return unlz4(data, size, expected);
  return Bytes::failure("unknown chunk compression '" + compression + "' (zstd, lz4 or none)");
}

std::vector<uint8_t> compress(Compression compression, const std::vector<uint8_t>& data) {
  if (compression == Compression::kZstd) {
    std::vector<uint8_t> out(ZSTD_compressBound(data.size()));
    const size_t n = ZSTD_compress(out.data(), out.size(), data.data(), data.size(), 3);
    out.resize(ZSTD_isError(n) ? 0 : n);
    return out;
  }
  if (compression == Compression::kLz4) {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentSize = data.size();
    std::vector<uint8_t> out(LZ4F_compressFrameBound(data.size(), &prefs));
    const size_t n = LZ4F_compressFrame(out.data(), out.size(), data.data(), data.size(), &prefs);
    out.resize(LZ4F_isError(n) ? 0 : n);
    return out;
  }
  return data;
}

}  // namespace detail
}  // namespace rgbdmap::mcap
