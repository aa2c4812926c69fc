#pragma once
// Private helpers shared by the convert_*.cpp files: the generic wire encode/decode and the shared types.
#include <climits>
#include <exception>
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/proto/validate.hpp"
#include "rgbdmap_lcm/header_t.hpp"
#include "rgbdmap_lcm/pose_t.hpp"

namespace rgbdmap::msg::detail {

rgbdmap_lcm::header_t toWire(const Header& h);
Header fromWire(const rgbdmap_lcm::header_t& w);
rgbdmap_lcm::pose_t toWire(const SE3& T);
/// Fails for non-finite values or a quaternion whose norm is off by more than 1e-6 (else normalises).
Result<SE3> fromWire(const rgbdmap_lcm::pose_t& w, const char* name);

template <typename Wire>
Bytes encodeWire(const Wire& wire) {
  Bytes out(static_cast<size_t>(wire.getEncodedSize()));
  wire.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

/// LCM decode of untrusted bytes (the generated decoder is hardened at build time, see harden_lcm.cmake).
template <typename Wire>
Result<Wire> decodeWire(const uint8_t* data, size_t size) {
  if (size > static_cast<size_t>(kMaxEnvelopeBytes)) return Result<Wire>::failure("too large");
  if (size < 8) return Result<Wire>::failure("truncated: no type hash");
  Wire wire;
  int used = -1;
  try {
    used = wire.decode(data, 0, static_cast<int>(size));
  } catch (const std::exception& e) {  // defence in depth: the guards should make this unreachable
    return Result<Wire>::failure(std::string("malformed: ") + e.what());
  }
  if (used < 0) return Result<Wire>::failure("truncated or wrong type: LCM decode failed");
  if (static_cast<size_t>(used) != size) return Result<Wire>::failure("malformed: trailing bytes");
  return wire;
}

template <typename Msg, typename ToWire>
Result<Bytes> encodeChecked(const Msg& m, ToWire to_wire) {
  Status s = validate(m);
  if (!s) return Result<Bytes>::failure(s.error());
  return encodeWire(to_wire(m));
}

template <typename Msg, typename Wire>
Result<Msg> decodeChecked(const uint8_t* data, size_t size, Result<Msg> (*from_wire)(const Wire&)) {
  Result<Wire> wire = decodeWire<Wire>(data, size);
  if (!wire) return Result<Msg>::failure(wire.error());
  Result<Msg> m = from_wire(*wire);
  if (!m) return m;
  Status s = validate(*m);
  if (!s) return Result<Msg>::failure(s.error());
  return m;
}

/// Count field for an encoder: the vectors' sizes are bounded by validate(), so this never truncates.
template <typename C>
int32_t count(const C& c) {
  return static_cast<int32_t>(c.size());
}

}  // namespace rgbdmap::msg::detail

/// The explicit specialisations of encodePayload/decodePayload (codec.hpp) for one message, in namespace msg.
#define RGBDMAP_PROTO_CODEC(Msg, to_wire, from_wire)            \
  template <>                                                   \
  Result<Bytes> encodePayload(const Msg& m) {                   \
    return detail::encodeChecked(m, to_wire);                   \
  }                                                             \
  template <>                                                   \
  Result<Msg> decodePayload(const uint8_t* data, size_t size) { \
    return detail::decodeChecked(data, size, from_wire);        \
  }
