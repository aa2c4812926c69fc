#pragma once
// Internal: bytes of the map store's records (framing and the two payloads). Pure functions, no I/O.
//
// Record (all integers little-endian, written byte by byte):
//   offset size field
//   0      4    magic "RDMS"
//   4      2    format version (kMapStoreFormatVersion)
//   6      2    type: 1 keyframe, 2 loop
//   8      4    payload length in bytes (<= kMaxPayloadBytes)
//   12     4    CRC-32 (zlib) of the payload
//   16     4    CRC-32 (zlib) of bytes 0..15
//   20     ...  payload
// The header has its own CRC so that a trusted length tells where the next record starts; a damaged header
// is skipped by searching for the next magic whose header CRC verifies.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap::store {

using msg::Bytes;

constexpr size_t kRecordHeaderSize = 20;
constexpr uint32_t kMaxPayloadBytes = 128u << 20;  ///< above msg::kMaxEnvelopeBytes + ids
constexpr uint8_t kRecordMagic[4] = {'R', 'D', 'M', 'S'};

enum class RecordType : uint16_t { kKeyframe = 1, kLoop = 2 };

struct RecordHeader {
  uint16_t version = 0;
  uint16_t type = 0;
  uint32_t payload_size = 0;
  uint32_t payload_crc = 0;
};

/// Little-endian integers and doubles appended to a buffer (byte by byte: no struct memcpy).
class ByteWriter {
 public:
  explicit ByteWriter(Bytes* out) : out_(out) {}
  void u16(uint16_t v) { le(v, 2); }
  void u32(uint32_t v) { le(v, 4); }
  void i64(int64_t v) { le(static_cast<uint64_t>(v), 8); }
  void f64(double v) {
    uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    le(bits, 8);
  }

 private:
  void le(uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i) out_->push_back(static_cast<uint8_t>(v >> (8 * i)));
  }
  Bytes* out_;
};

/// Reads little-endian values; the caller checks the total size first.
class ByteReader {
 public:
  explicit ByteReader(const uint8_t* data) : p_(data) {}
  uint16_t u16() { return static_cast<uint16_t>(le(2)); }
  uint32_t u32() { return static_cast<uint32_t>(le(4)); }
  int64_t i64() { return static_cast<int64_t>(le(8)); }
  double f64() {
    const uint64_t bits = le(8);
    double v = 0.0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }

 private:
  uint64_t le(int bytes) {
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= static_cast<uint64_t>(p_[i]) << (8 * i);
    p_ += bytes;
    return v;
  }
  const uint8_t* p_;
};

/// Little-endian into a buffer of known size.
inline void putLE(uint8_t* p, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

uint32_t crc32Of(const uint8_t* data, size_t size);

/// Header + payload of one record of the current format version.
Bytes frameRecord(RecordType type, const Bytes& payload);
/// nullopt unless the magic and the header CRC match and the length is within kMaxPayloadBytes.
std::optional<RecordHeader> parseRecordHeader(const uint8_t* header);
/// Checks version, type and payload CRC; the reason otherwise.
Status verifyRecord(const RecordHeader& header, RecordType expected, const uint8_t* payload);

/// node_id (int64), session (int64), then msg::encodePayload(keyframe) (which validates the keyframe).
Result<Bytes> encodeKeyframePayload(const StoredKeyframe& keyframe);
Result<StoredKeyframe> decodeKeyframePayload(const uint8_t* data, size_t size);

/// Fixed 412 bytes: from, to (int64), T_from_to rows 0..2 (12 doubles, row-major), information (36
/// doubles, row-major), inliers (int32), motion_measure (double). Both directions check the values.
Result<Bytes> encodeLoopPayload(const StoredLoop& loop);
Result<StoredLoop> decodeLoopPayload(const uint8_t* data, size_t size);
Status validateLoop(const StoredLoop& loop);

}  // namespace rgbdmap::store
