// KeyStore, hex keys, session ids, reject reason names.
#include <openssl/rand.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap::msg {

Result<Bytes> newKey() {
  Bytes key(32);
  if (RAND_bytes(key.data(), static_cast<int>(key.size())) != 1)
    return Result<Bytes>::failure("no random key: OpenSSL's generator failed");
  return key;
}

std::string toHex(const Bytes& bytes) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (const uint8_t b : bytes) {
    out += digits[b >> 4];
    out += digits[b & 15];
  }
  return out;
}

KeyStore KeyStore::openMode(bool warn) {
  if (warn)
    log::warn(
        "OPEN MODE: message signatures are NOT checked and unknown senders are accepted. "
        "Use only for local demos.");
  KeyStore store;
  store.open_ = true;
  return store;
}

Status KeyStore::add(const std::string& sender, const Bytes& key) {
  if (!isValidId(sender)) return Status::failure("invalid sender id '" + sender + "'");
  if (key.size() < kMinKeyBytes) return Status::failure("key for '" + sender + "' shorter than 16 bytes");
  keys_[sender] = key;
  return Status::success();
}

const Bytes* KeyStore::find(const std::string& sender) const {
  const auto it = keys_.find(sender);
  return it == keys_.end() ? nullptr : &it->second;
}

Result<Bytes> parseHexKey(const std::string& hex) {
  if (hex.size() % 2 != 0 || hex.size() < 2 * kMinKeyBytes || hex.size() > 1024)
    return Result<Bytes>::failure("key must be an even number of hex digits, at least 32");
  auto nibble = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  Bytes key(hex.size() / 2);
  for (size_t i = 0; i < key.size(); ++i) {
    const int hi = nibble(hex[2 * i]), lo = nibble(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) return Result<Bytes>::failure("key has a non-hex character");
    key[i] = static_cast<uint8_t>(hi << 4 | lo);
  }
  return key;
}

int64_t newSessionId() {
  using namespace std::chrono;
  return duration_cast<microseconds>(system_clock::now().time_since_epoch()).count();
}

const char* toString(RejectReason reason) {
  switch (reason) {
    case RejectReason::kTruncated:
      return "truncated";
    case RejectReason::kTooLarge:
      return "too large";
    case RejectReason::kMalformed:
      return "malformed";
    case RejectReason::kWrongSchemaVersion:
      return "wrong schema version";
    case RejectReason::kUnknownType:
      return "unknown type";
    case RejectReason::kInvalidSender:
      return "invalid sender";
    case RejectReason::kUnknownSender:
      return "unknown sender";
    case RejectReason::kBadSignature:
      return "bad signature";
    case RejectReason::kReplayedSeq:
      return "replayed seq";
    case RejectReason::kWrongType:
      return "wrong type";
    case RejectReason::kHeaderMismatch:
      return "header mismatch";
    case RejectReason::kInvalidContent:
      return "invalid content";
    case RejectReason::kCount:
      break;
  }
  return "unknown";
}

void RejectCounters::add(RejectReason reason, const std::string& detail) {
  const uint64_t n = counts_[static_cast<int>(reason)].fetch_add(1, std::memory_order_relaxed) + 1;
  uint64_t suppressed = 0;
  if (limiter_.allow(&suppressed))
    log::warn("rejected message: ", toString(reason), detail.empty() ? "" : " (" + detail + ")", "; ", n,
              " so far for this reason",
              suppressed ? ", " + std::to_string(suppressed) + " lines suppressed" : "");
}

uint64_t RejectCounters::total() const {
  uint64_t sum = 0;
  for (const auto& c : counts_) sum += c.load();
  return sum;
}

Result<KeyStore> readKeysFile(const std::string& path, KeyStore keys) {
  std::ifstream in(path);
  if (!in) {
    std::error_code ec;
    const std::string resolved = std::filesystem::absolute(path, ec).lexically_normal().string();
    return Result<KeyStore>::failure("cannot read keys file " + path +
                                     (ec || resolved == path ? "" : " (" + resolved + ")"));
  }
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string id, hex, extra;
    if (!(fields >> id)) continue;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    if (!(fields >> hex) || (fields >> extra))
      return Result<KeyStore>::failure(where + "expected 'robot_id hexkey'");
    auto key = parseHexKey(hex);
    if (!key) return Result<KeyStore>::failure(where + key.error());
    if (keys.find(id)) return Result<KeyStore>::failure(where + "second key for '" + id + "'");
    if (const Status s = keys.add(id, *key); !s) return Result<KeyStore>::failure(where + s.error());
  }
  return keys;
}

}  // namespace rgbdmap::msg
