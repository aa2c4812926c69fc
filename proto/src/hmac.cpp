#include "hmac.hpp"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

namespace rgbdmap::msg::detail {

bool hmacSha256(const Bytes& key, const uint8_t* data, size_t size, Mac* out) {
  unsigned int len = 0;
  static const uint8_t kEmpty = 0;
  const unsigned char* r =
      HMAC(EVP_sha256(), key.empty() ? &kEmpty : key.data(), static_cast<int>(key.size()),
           size == 0 ? &kEmpty : data, size, out->data(), &len);
  return r != nullptr && len == out->size();
}

bool equalConstantTime(const uint8_t* a, const uint8_t* b, size_t size) {
  return CRYPTO_memcmp(a, b, size) == 0;
}

}  // namespace rgbdmap::msg::detail
