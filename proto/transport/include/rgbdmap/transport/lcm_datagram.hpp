#pragma once
// The part of LCM's UDP multicast wire format the lossy relay needs (lcm/lcm_udpm.c, big-endian):
//   short message  "LC02" u32 magic, u32 sequence number, channel NUL-terminated, payload
//   fragment       "LC03" u32 magic, u32 sequence number, u32 message size, u32 fragment offset,
//                  u16 fragment number, u16 fragment count, (fragment 0 only) channel, payload
// and the drop decisions of rgbdmap-lossy-relay (apps/lossy_relay). Header-only.
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace rgbdmap::relay {

constexpr uint32_t kLcmShortMagic = 0x4c433032;     // "LC02"
constexpr uint32_t kLcmFragmentMagic = 0x4c433033;  // "LC03"

struct LcmDatagramHeader {
  bool fragment = false;
  uint32_t sequence = 0;
  uint16_t fragment_no = 0;     ///< 0 for a short message
  uint16_t fragment_count = 1;  ///< 1 for a short message
};

inline uint32_t readBigEndian32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

/// False when the datagram is not an LCM datagram (too short, unknown magic, fragment number out of range).
inline bool parseLcmDatagram(const uint8_t* data, size_t size, LcmDatagramHeader* out) {
  if (size < 8) return false;
  const uint32_t magic = readBigEndian32(data);
  out->sequence = readBigEndian32(data + 4);
  if (magic == kLcmShortMagic) {
    out->fragment = false;
    out->fragment_no = 0;
    out->fragment_count = 1;
    return true;
  }
  if (magic != kLcmFragmentMagic || size < 20) return false;
  out->fragment = true;
  out->fragment_no = static_cast<uint16_t>((data[16] << 8) | data[17]);
  out->fragment_count = static_cast<uint16_t>((data[18] << 8) | data[19]);
  return out->fragment_count > 0 && out->fragment_no < out->fragment_count;
}

/// Loss probability of a UDP datagram of `payload_bytes` when each IP packet on a link of `mtu` is lost with
/// probability `packet_loss` independently (IPv4: 20-byte header, fragments carry multiples of 8 bytes, the
/// datagram is lost when any fragment is). mtu 0: the datagram itself is the unit of loss.
inline double datagramLoss(double packet_loss, size_t payload_bytes, int mtu) {
  if (mtu <= 0 || packet_loss <= 0.0) return packet_loss;
  const size_t per_fragment = static_cast<size_t>((mtu - 20) / 8 * 8);
  const size_t fragments = (payload_bytes + 8 + per_fragment - 1) / per_fragment;
  return 1.0 - std::pow(1.0 - packet_loss, static_cast<double>(fragments));
}

inline uint64_t splitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Whole-message drop decision: a pure function of (seed, sender, LCM sequence number), so every fragment of
/// one message gets the same answer without the relay keeping any state per message.
inline bool dropMessage(uint64_t seed, uint32_t sender_ip, uint16_t sender_port, uint32_t sequence,
                        double probability) {
  if (probability <= 0.0) return false;
  const uint64_t sender = (uint64_t{sender_ip} << 16) | sender_port;
  const uint64_t h = splitMix64(splitMix64(seed ^ splitMix64(sender)) ^ sequence);
  return static_cast<double>(h >> 11) * 0x1.0p-53 < probability;
}

}  // namespace rgbdmap::relay
