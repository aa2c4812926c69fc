#pragma once
// Payload encoding: internal message <-> its LCM encoding (8-byte type hash + fields). Both directions
// validate (validate.hpp); decoding treats the bytes as untrusted: a wrong type hash, a count that does not
// fit the bytes, trailing bytes, a non-finite number, a non-unit quaternion (normalised within 1e-6,
// rejected beyond), an out-of-range id or a size mismatch is an error with a reason, never a crash.
// Reentrant, no shared state.
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::msg {

/// Defined for every message struct in messages.hpp (explicit specialisations in proto/src).
template <typename T>
Result<Bytes> encodePayload(const T& message);
template <typename T>
Result<T> decodePayload(const uint8_t* data, size_t size);
template <typename T>
Result<T> decodePayload(const Bytes& bytes) {
  return decodePayload<T>(bytes.data(), bytes.size());
}

/// Decodes (and fully validates) a keyframe's images with rgbdmap/codec/image_codec.hpp.
Result<DecodedImages> decodeKeyframeImages(const Keyframe& keyframe);

}  // namespace rgbdmap::msg
