#pragma once
// Internal helpers shared by the depth and colour codecs: the blob header (layout documented in
// image_codec.hpp) and zstd wrappers that refuse any frame whose size is not exactly the expected one.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::detail {

enum class BlobKind : uint8_t { kDepth, kColor };

struct BlobHeader {
  uint8_t method = 0;  ///< DepthFilter or ColorCodec id
  uint16_t width = 0;
  uint16_t height = 0;
  uint16_t aux = 0;
};

/// Both sides in 1..kMaxImageSide.
Status checkImageSize(int width, int height, const char* what);

/// Starts a blob: writes the header with a zero payload length into an empty `blob`.
void beginBlob(BlobKind kind, const BlobHeader& header, std::vector<uint8_t>& blob);
/// Sets the header's payload length and checksum from the blob; fails if the payload exceeds 4 GiB.
Status finishBlob(std::vector<uint8_t>& blob);

/// Reads and checks a header: magic, version, that the declared payload length is exactly
/// `size - kImageBlobHeaderSize`, the checksum, the size range and the expected size. The method and aux
/// fields are left to the caller.
Result<BlobHeader> parseBlobHeader(const uint8_t* data, size_t size, BlobKind kind, int expected_width,
                                   int expected_height);

/// Appends one zstd frame (content size declared; no frame checksum, the blob has one) of [src, src + size)
/// to `out`.
Status appendZstdFrame(const uint8_t* src, size_t size, int level, std::vector<uint8_t>& out);
/// Decompresses [src, src + size), which must be exactly one zstd frame declaring exactly
/// `expected_size` content bytes. Nothing is allocated before those checks pass.
Result<std::vector<uint8_t>> decompressZstdFrame(const uint8_t* src, size_t size, size_t expected_size);

inline void putU16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v & 0xFF);
  p[1] = static_cast<uint8_t>(v >> 8);
}
inline uint16_t getU16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

/// Zigzag maps small signed residuals to small unsigned codes: 0,-1,1,-2,2 -> 0,1,2,3,4.
inline uint16_t zigzag16(uint16_t d) { return static_cast<uint16_t>((d << 1) ^ ((d & 0x8000) ? 0xFFFF : 0)); }
inline uint16_t unzigzag16(uint16_t z) { return static_cast<uint16_t>((z >> 1) ^ ((z & 1) ? 0xFFFF : 0)); }

}  // namespace rgbdmap::detail
