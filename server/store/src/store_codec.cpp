#include "store_codec.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "rgbdmap/proto/codec.hpp"

namespace rgbdmap::store {
namespace {

constexpr size_t kLoopPayloadSize = 8 + 8 + 12 * 8 + 36 * 8 + 4 + 8;

}  // namespace

uint32_t crc32Of(const uint8_t* data, size_t size) {
  uLong crc = crc32(0L, Z_NULL, 0);
  constexpr size_t kChunk = 1u << 30;  // crc32 takes a uInt length
  for (size_t at = 0; at < size; at += kChunk)
    crc = crc32(crc, data + at, static_cast<uInt>(std::min(kChunk, size - at)));
  return static_cast<uint32_t>(crc);
}

Bytes frameRecord(RecordType type, const Bytes& payload) {
  Bytes out(kRecordHeaderSize + payload.size());
  uint8_t* h = out.data();
  std::memcpy(h, kRecordMagic, 4);
  putLE(h + 4, kMapStoreFormatVersion, 2);
  putLE(h + 6, static_cast<uint16_t>(type), 2);
  putLE(h + 8, payload.size(), 4);
  putLE(h + 12, crc32Of(payload.data(), payload.size()), 4);
  putLE(h + 16, crc32Of(h, 16), 4);
  if (!payload.empty()) std::memcpy(h + kRecordHeaderSize, payload.data(), payload.size());
  return out;
}

std::optional<RecordHeader> parseRecordHeader(const uint8_t* header) {
  if (std::memcmp(header, kRecordMagic, 4) != 0) return std::nullopt;
  ByteReader r(header + 4);
  RecordHeader h;
  h.version = r.u16();
  h.type = r.u16();
  h.payload_size = r.u32();
  h.payload_crc = r.u32();
  const uint32_t header_crc = r.u32();
  if (header_crc != crc32Of(header, 16) || h.payload_size > kMaxPayloadBytes) return std::nullopt;
  return h;
}

Status verifyRecord(const RecordHeader& header, RecordType expected, const uint8_t* payload) {
  if (header.version != kMapStoreFormatVersion)
    return Status::failure("record format version " + std::to_string(header.version) + ", expected " +
                           std::to_string(kMapStoreFormatVersion));
  if (header.type != static_cast<uint16_t>(expected))
    return Status::failure("record type " + std::to_string(header.type) + ", expected " +
                           std::to_string(static_cast<int>(expected)));
  if (crc32Of(payload, header.payload_size) != header.payload_crc)
    return Status::failure("payload CRC mismatch");
  return Status::success();
}

Result<Bytes> encodeKeyframePayload(const StoredKeyframe& keyframe) {
  Result<Bytes> message = msg::encodePayload(keyframe.keyframe);
  if (!message) return Result<Bytes>::failure("invalid keyframe: " + message.error());
  Bytes out;
  out.reserve(16 + message->size());
  ByteWriter w(&out);
  w.i64(keyframe.node_id);
  w.i64(keyframe.session);
  out.insert(out.end(), message->begin(), message->end());
  return out;
}

Result<StoredKeyframe> decodeKeyframePayload(const uint8_t* data, size_t size) {
  if (size < 16) return Result<StoredKeyframe>::failure("keyframe payload shorter than 16 bytes");
  ByteReader r(data);
  StoredKeyframe out;
  out.node_id = r.i64();
  out.session = r.i64();
  if (out.node_id < 0) return Result<StoredKeyframe>::failure("negative node id");
  Result<msg::Keyframe> keyframe = msg::decodePayload<msg::Keyframe>(data + 16, size - 16);
  if (!keyframe) return Result<StoredKeyframe>::failure("keyframe message: " + keyframe.error());
  out.keyframe = std::move(keyframe).value();
  return out;
}

Status validateLoop(const StoredLoop& loop) {
  if (loop.from_node < 0 || loop.to_node < 0) return Status::failure("negative node id");
  if (loop.from_node == loop.to_node) return Status::failure("loop from a node to itself");
  if (!se3::isValid(loop.T_from_to, 1e-6)) return Status::failure("T_from_to not finite or not a rotation");
  const Mat6& info = loop.information;
  if (!info.allFinite()) return Status::failure("information not finite");
  const double scale = std::max(1.0, info.cwiseAbs().maxCoeff());
  if ((info - info.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale)
    return Status::failure("information not symmetric");
  if (loop.inliers < 0) return Status::failure("negative inlier count");
  if (!std::isfinite(loop.motion_measure)) return Status::failure("motion measure not finite");
  if (loop.inlier_pairs.size() > kMaxStoredLoopPairs) return Status::failure("too many inlier pairs");
  for (const auto& [a, b] : loop.inlier_pairs)
    if (a < 0 || b < 0) return Status::failure("negative feature index in an inlier pair");
  return Status::success();
}

Result<Bytes> encodeLoopPayload(const StoredLoop& loop) {
  if (Status s = validateLoop(loop); !s) return Result<Bytes>::failure("invalid loop: " + s.error());
  Bytes out;
  out.reserve(kLoopPayloadSize);
  ByteWriter w(&out);
  w.i64(loop.from_node);
  w.i64(loop.to_node);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) w.f64(loop.T_from_to.matrix()(r, c));
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) w.f64(loop.information(r, c));
  w.u32(static_cast<uint32_t>(loop.inliers));
  w.f64(loop.motion_measure);
  if (loop.inlier_pairs.empty()) return out;  // the original 412-byte record
  w.u32(static_cast<uint32_t>(loop.inlier_pairs.size()));
  for (const auto& [a, b] : loop.inlier_pairs) {
    w.u32(static_cast<uint32_t>(a));
    w.u32(static_cast<uint32_t>(b));
  }
  return out;
}

Result<StoredLoop> decodeLoopPayload(const uint8_t* data, size_t size) {
  // The fixed part, optionally followed by the inlier pairs: count (u32), then count x (u32, u32).
  if (size != kLoopPayloadSize && size < kLoopPayloadSize + 4)
    return Result<StoredLoop>::failure("loop payload of " + std::to_string(size) + " bytes, expected " +
                                       std::to_string(kLoopPayloadSize) + " or more with inlier pairs");
  ByteReader r(data);
  StoredLoop loop;
  loop.from_node = r.i64();
  loop.to_node = r.i64();
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int row = 0; row < 3; ++row)
    for (int c = 0; c < 4; ++c) T(row, c) = r.f64();
  loop.T_from_to.matrix() = T;
  for (int row = 0; row < 6; ++row)
    for (int c = 0; c < 6; ++c) loop.information(row, c) = r.f64();
  const uint32_t inliers = r.u32();
  if (inliers > static_cast<uint32_t>(std::numeric_limits<int>::max()))
    return Result<StoredLoop>::failure("inlier count out of range");
  loop.inliers = static_cast<int>(inliers);
  loop.motion_measure = r.f64();
  if (size > kLoopPayloadSize) {
    const uint32_t n = r.u32();
    if (n == 0 || n > kMaxStoredLoopPairs || size != kLoopPayloadSize + 4 + 8 * static_cast<size_t>(n))
      return Result<StoredLoop>::failure("loop payload of " + std::to_string(size) +
                                         " bytes does not hold its " + std::to_string(n) + " inlier pairs");
    loop.inlier_pairs.reserve(n);
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t a = r.u32(), b = r.u32();
      if (a > static_cast<uint32_t>(std::numeric_limits<int>::max()) ||
          b > static_cast<uint32_t>(std::numeric_limits<int>::max()))
        return Result<StoredLoop>::failure("inlier pair index out of range");
      loop.inlier_pairs.emplace_back(static_cast<int>(a), static_cast<int>(b));
    }
  }
  if (Status s = validateLoop(loop); !s) return Result<StoredLoop>::failure("invalid loop: " + s.error());
  return loop;
}

}  // namespace rgbdmap::store
