#pragma once
// Internal: an adaptive binary range coder (the carry-less LZMA design: 32-bit range, 11-bit probabilities,
// a 64-bit low with a one-byte cache for carries) and the binarisations the depth coder builds on it.
//
// Each call codes one bit under a Prob, a 16-bit estimate of P(bit = 0) in units of 1/2048 that adapts
// towards every bit coded under it. Encoder and decoder must make the same sequence of calls with the same
// probabilities; the decoder then returns the encoder's bits. The decoder reads untrusted bytes: reading
// past the end yields zero bytes and is counted (overrun()), never read from memory.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace rgbdmap::detail {

constexpr int kProbBits = 11;
constexpr uint32_t kProbOne = 1u << kProbBits;
constexpr int kProbShift = 5;  ///< adaptation rate: each bit moves the estimate 1/16 of the way
constexpr uint32_t kRangeTop = 1u << 24;

/// The adaptation starts fast (a count-like average over the first bits seen) and settles at
/// 1 / 2^kProbShift, so rarely used contexts learn quickly and busy ones stay stable.
struct Prob {
  uint16_t p = kProbOne / 2;
  uint8_t seen = 0;
  int shift() {
    static constexpr uint8_t kShift[] = {1, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5};
    const int s = seen < sizeof(kShift) ? kShift[seen] : kProbShift;
    if (seen < sizeof(kShift)) ++seen;
    return s;
  }
  void update(int bit) {
    const int s = shift();
    if (bit == 0)
      p = static_cast<uint16_t>(p + ((kProbOne - p) >> s));
    else
      p = static_cast<uint16_t>(p - (p >> s));
    p = std::clamp<uint16_t>(p, 31, kProbOne - 31);
  }
};

class RangeEncoder {
 public:
  explicit RangeEncoder(std::vector<uint8_t>& out) : out_(out) {}

  void bit(Prob& prob, int bit) {
    const uint32_t bound = (range_ >> kProbBits) * prob.p;
    if (bit == 0) {
      range_ = bound;
    } else {
      low_ += bound;
      range_ -= bound;
    }
    prob.update(bit);
    while (range_ < kRangeTop) {
      range_ <<= 8;
      shiftLow();
    }
  }

  /// Writes the last bytes; the encoder must not be used afterwards.
  void finish() {
    for (int i = 0; i < 5; ++i) shiftLow();
  }

 private:
  void shiftLow() {
    if (static_cast<uint32_t>(low_) < 0xFF000000u || (low_ >> 32) != 0) {
      const auto carry = static_cast<uint8_t>(low_ >> 32);
      uint8_t pending = cache_;
      do {
        out_.push_back(static_cast<uint8_t>(pending + carry));
        pending = 0xFF;
      } while (--cache_size_ != 0);
      cache_ = static_cast<uint8_t>(low_ >> 24);
    }
    ++cache_size_;
    low_ = (low_ & 0x00FFFFFFu) << 8;
  }

  std::vector<uint8_t>& out_;
  uint64_t low_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint8_t cache_ = 0;
  uint64_t cache_size_ = 1;
};

class RangeDecoder {
 public:
  RangeDecoder(const uint8_t* data, size_t size) : data_(data), size_(size) {
    for (int i = 0; i < 5; ++i) code_ = (code_ << 8) | next();
  }

  int bit(Prob& prob) {
    const uint32_t bound = (range_ >> kProbBits) * prob.p;
    int bit;
    if (code_ < bound) {
      range_ = bound;
      bit = 0;
    } else {
      code_ -= bound;
      range_ -= bound;
      bit = 1;
    }
    prob.update(bit);
    while (range_ < kRangeTop) {
      range_ <<= 8;
      code_ = (code_ << 8) | next();
    }
    return bit;
  }

  /// Bytes read so far (at most the input size) and reads that went past the end.
  size_t consumed() const { return pos_ < size_ ? pos_ : size_; }
  size_t overrun() const { return pos_ > size_ ? pos_ - size_ : 0; }

 private:
  uint32_t next() {
    const uint32_t byte = pos_ < size_ ? data_[pos_] : 0;
    ++pos_;
    return byte;
  }

  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
  uint32_t code_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
};

/// Adapters that let one templated function both encode and decode: `bit(prob, b)` codes b and returns it
/// on the encoder, ignores b and returns the decoded bit on the decoder.
struct BitWriter {
  RangeEncoder& rc;
  int bit(Prob& prob, int b) {
    rc.bit(prob, b);
    return b;
  }
};
struct BitReader {
  RangeDecoder& rc;
  int bit(Prob& prob, int /*b*/) { return rc.bit(prob); }
};

/// An adaptive Elias-gamma code for values 0..2^30 - 2: the bit length of v + 1 in unary, then its bits
/// below the leading one, every position with a probability of its own.
struct GammaModel {
  static constexpr int kMaxBits = 30;
  Prob length[kMaxBits + 1];
  Prob bits[kMaxBits];
};

/// Codes v (encoder) or decodes into the result (decoder; v is ignored). Returns -1 only when a decoder
/// reads a length beyond kMaxBits, which only forged input produces.
template <class Io>
int64_t codeGamma(Io& io, GammaModel& m, uint32_t v) {
  const uint32_t x = v + 1;
  int n = 0;
  while (n < GammaModel::kMaxBits && io.bit(m.length[n], (x >> (n + 1)) != 0) == 1) ++n;
  if (n >= GammaModel::kMaxBits) return -1;
  uint32_t y = 1;
  for (int i = n - 1; i >= 0; --i) y = (y << 1) | static_cast<uint32_t>(io.bit(m.bits[i], (x >> i) & 1u));
  return static_cast<int64_t>(y) - 1;
}

}  // namespace rgbdmap::detail
