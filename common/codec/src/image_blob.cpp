#include "image_blob.hpp"

#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <memory>
#include <string>

#include "rgbdmap/codec/image_codec.hpp"

namespace rgbdmap::detail {
namespace {

constexpr size_t kPayloadLengthOffset = 12;
constexpr size_t kChecksumOffset = 16;

const char* magicFor(BlobKind kind) { return kind == BlobKind::kDepth ? "RDMD" : "RDMC"; }
const char* nameFor(BlobKind kind) { return kind == BlobKind::kDepth ? "depth blob" : "colour blob"; }

uint32_t getU32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}

void putU32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>((v >> (8 * i)) & 0xFF);
}

/// CRC-32 of header bytes 0..15 followed by the payload.
uint32_t blobChecksum(const uint8_t* blob, size_t size) {
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, blob, static_cast<uInt>(kChecksumOffset));
  for (size_t at = kImageBlobHeaderSize; at < size;) {  // zlib takes at most 4 GiB - 1 per call
    const size_t chunk = std::min<size_t>(size - at, 1u << 30);
    crc = crc32(crc, blob + at, static_cast<uInt>(chunk));
    at += chunk;
  }
  return static_cast<uint32_t>(crc);
}

struct CCtxDeleter {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
};
struct DCtxDeleter {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

}  // namespace

Status checkImageSize(int width, int height, const char* what) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide)
    return Status::failure(std::string(what) + " size " + std::to_string(width) + "x" +
                           std::to_string(height) + " outside 1.." + std::to_string(kMaxImageSide));
  return Status::success();
}

void beginBlob(BlobKind kind, const BlobHeader& header, std::vector<uint8_t>& blob) {
  blob.assign(kImageBlobHeaderSize, 0);
  std::memcpy(blob.data(), magicFor(kind), 4);
  blob[4] = kImageBlobVersion;
  blob[5] = header.method;
  putU16(&blob[6], header.width);
  putU16(&blob[8], header.height);
  putU16(&blob[10], header.aux);
}

Status finishBlob(std::vector<uint8_t>& blob) {
  const size_t payload = blob.size() - kImageBlobHeaderSize;
  if (payload > std::numeric_limits<uint32_t>::max()) return Status::failure("payload exceeds 4 GiB");
  putU32(&blob[kPayloadLengthOffset], static_cast<uint32_t>(payload));
  putU32(&blob[kChecksumOffset], blobChecksum(blob.data(), blob.size()));
  blob.shrink_to_fit();  // the encoders sized it for the worst case
  return Status::success();
}

Result<BlobHeader> parseBlobHeader(const uint8_t* data, size_t size, BlobKind kind, int expected_width,
                                   int expected_height) {
  using R = Result<BlobHeader>;
  const std::string name = nameFor(kind);
  if (const Status s = checkImageSize(expected_width, expected_height, "expected"); !s)
    return R::failure(s.error());
  if (data == nullptr || size < kImageBlobHeaderSize)
    return R::failure(name + ": " + std::to_string(size) + " bytes, shorter than its header");
  if (std::memcmp(data, magicFor(kind), 4) != 0) return R::failure(name + ": bad magic");
  if (data[4] != kImageBlobVersion)
    return R::failure(name + ": unsupported format version " + std::to_string(data[4]));
  const uint32_t declared = getU32(data + kPayloadLengthOffset);
  if (declared != size - kImageBlobHeaderSize)
    return R::failure(name + ": declares a " + std::to_string(declared) + "-byte payload, has " +
                      std::to_string(size - kImageBlobHeaderSize));
  if (getU32(data + kChecksumOffset) != blobChecksum(data, size))
    return R::failure(name + ": checksum mismatch");
  BlobHeader h;
  h.method = data[5];
  h.width = getU16(data + 6);
  h.height = getU16(data + 8);
  h.aux = getU16(data + 10);
  if (const Status s = checkImageSize(h.width, h.height, (name + ": declared").c_str()); !s)
    return R::failure(s.error());
  if (h.width != expected_width || h.height != expected_height)
    return R::failure(name + ": declares " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                      ", expected " + std::to_string(expected_width) + "x" + std::to_string(expected_height));
  return h;
}

Status appendZstdFrame(const uint8_t* src, size_t size, int level, std::vector<uint8_t>& out) {
  const std::unique_ptr<ZSTD_CCtx, CCtxDeleter> cctx(ZSTD_createCCtx());
  if (!cctx) return Status::failure("zstd: cannot create a compression context");
  ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_checksumFlag, 0);  // the blob CRC covers the frame
  ZSTD_CCtx_setParameter(cctx.get(), ZSTD_c_contentSizeFlag, 1);
  const size_t start = out.size();
  out.resize(start + ZSTD_compressBound(size));
  const size_t written = ZSTD_compress2(cctx.get(), out.data() + start, out.size() - start, src, size);
  if (ZSTD_isError(written)) {
    out.resize(start);
    return Status::failure(std::string("zstd: ") + ZSTD_getErrorName(written));
  }
  out.resize(start + written);
  return Status::success();
}

Result<std::vector<uint8_t>> decompressZstdFrame(const uint8_t* src, size_t size, size_t expected_size) {
  using R = Result<std::vector<uint8_t>>;
  const unsigned long long content = ZSTD_getFrameContentSize(src, size);
  if (content == ZSTD_CONTENTSIZE_ERROR) return R::failure("zstd: payload is not a zstd frame");
  if (content == ZSTD_CONTENTSIZE_UNKNOWN) return R::failure("zstd: frame does not declare its content size");
  if (content != expected_size)
    return R::failure("zstd: frame declares " + std::to_string(content) + " content bytes, expected " +
                      std::to_string(expected_size));
  const size_t frame_size = ZSTD_findFrameCompressedSize(src, size);
  if (ZSTD_isError(frame_size)) return R::failure(std::string("zstd: ") + ZSTD_getErrorName(frame_size));
  if (frame_size != size)
    return R::failure("zstd: " + std::to_string(size - frame_size) + " bytes after the frame");
  const std::unique_ptr<ZSTD_DCtx, DCtxDeleter> dctx(ZSTD_createDCtx());
  if (!dctx) return R::failure("zstd: cannot create a decompression context");
  std::vector<uint8_t> out(expected_size);
  const size_t got = ZSTD_decompressDCtx(dctx.get(), out.data(), out.size(), src, size);
  if (ZSTD_isError(got)) return R::failure(std::string("zstd: ") + ZSTD_getErrorName(got));
  if (got != expected_size)
    return R::failure("zstd: decompressed " + std::to_string(got) + " bytes, expected " +
                      std::to_string(expected_size));
  return out;
}

}  // namespace rgbdmap::detail
