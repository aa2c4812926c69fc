#pragma once
// Little-endian fields of MCAP records: a bounds-checked reader (any read past the end fails, yields
// zeros and stays failed) and an appending writer; chunk compression and decompression.
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/mcap/mcap.hpp"

namespace rgbdmap::mcap::detail {

class ByteReader {
 public:
  ByteReader(const uint8_t* bytes, size_t size) : bytes_(bytes), size_(size) {}
  template <typename T>
  T pod() {
    T v{};
    if (take(sizeof(T))) std::memcpy(&v, bytes_ + pos_ - sizeof(T), sizeof(T));
    return v;
  }
  std::string string() {
    const uint32_t n = pod<uint32_t>();
    if (!take(n)) return {};
    return std::string(reinterpret_cast<const char*>(bytes_ + pos_ - n), n);
  }
  /// A uint32-length-prefixed byte array.
  std::vector<uint8_t> bytes32() {
    const uint32_t n = pod<uint32_t>();
    if (!take(n)) return {};
    return std::vector<uint8_t>(bytes_ + pos_ - n, bytes_ + pos_);
  }
  std::map<std::string, std::string> stringMap() {
    std::map<std::string, std::string> out;
    const uint32_t n = pod<uint32_t>();
    if (!take(n)) return out;
    ByteReader inner(bytes_ + pos_ - n, n);
    while (!inner.failed() && inner.remaining() > 0) {
      std::string key = inner.string();
      std::string value = inner.string();
      if (!inner.failed()) out[std::move(key)] = std::move(value);
    }
    if (inner.failed()) failed_ = true;
    return out;
  }
  bool take(size_t n) {
    if (failed_ || n > size_ - pos_) return !(failed_ = true);
    pos_ += n;
    return true;
  }
  const uint8_t* at() const { return bytes_ + pos_; }
  size_t remaining() const { return failed_ ? 0 : size_ - pos_; }
  bool failed() const { return failed_; }

 private:
  const uint8_t* bytes_;
  size_t size_, pos_ = 0;
  bool failed_ = false;
};

class ByteWriter {
 public:
  template <typename T>
  void pod(T v) {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    out_.insert(out_.end(), p, p + sizeof(T));
  }
  void string(const std::string& s) {
    pod(static_cast<uint32_t>(s.size()));
    out_.insert(out_.end(), s.begin(), s.end());
  }
  void bytes32(const std::vector<uint8_t>& b) {
    pod(static_cast<uint32_t>(b.size()));
    out_.insert(out_.end(), b.begin(), b.end());
  }
  void raw(const uint8_t* p, size_t n) { out_.insert(out_.end(), p, p + n); }
  void stringMap(const std::map<std::string, std::string>& m) {
    ByteWriter inner;
    for (const auto& [k, v] : m) inner.string(k), inner.string(v);
    bytes32(inner.out_);
  }
  std::vector<uint8_t>& out() { return out_; }

 private:
  std::vector<uint8_t> out_;
};

/// Decompresses `size` bytes of a chunk into exactly `expected` bytes (at most kMaxChunkBytes; the output
/// grows with what the stream really yields, so a forged size allocates nothing it does not fill).
Result<std::vector<uint8_t>> decompress(const std::string& compression, const uint8_t* data, size_t size,
                                        uint64_t expected);
std::vector<uint8_t> compress(Compression compression, const std::vector<uint8_t>& data);

}  // namespace rgbdmap::mcap::detail
