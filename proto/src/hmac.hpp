#pragma once
// HMAC-SHA256 (OpenSSL libcrypto) and a constant-time comparison.
#include <array>
#include <cstddef>
#include <cstdint>

#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::msg::detail {

using Mac = std::array<uint8_t, 32>;
/// False only if libcrypto fails (it should not for SHA-256).
bool hmacSha256(const Bytes& key, const uint8_t* data, size_t size, Mac* out);
bool equalConstantTime(const uint8_t* a, const uint8_t* b, size_t size);

}  // namespace rgbdmap::msg::detail
