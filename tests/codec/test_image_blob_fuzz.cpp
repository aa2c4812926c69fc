// Seeded corruption: thousands of random mutations of valid blobs. Without a forged checksum every mutated
// blob must be rejected; with one (a deliberate forger) each must decode to an error with a reason or to an
// image of exactly the declared size. Never a crash; run it under -DRGBDMAP_SANITIZE=ON as well.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "codec/image_codec_test_util.hpp"
#include "rgbdmap/codec/image_codec.hpp"

namespace rgbdmap {
namespace {

using testing::Bytes;
using testing::colorBlob;
using testing::depthBlob;
using testing::putU16;
using testing::reseal;

constexpr int kW = 32, kH = 24;

struct Sample {
  std::string name;
  Bytes blob;
  bool is_depth;
  ColorCodec codec;
  int width, height;
};

std::vector<Sample> samples(int width, int height) {
  return {
      {"depth none", depthBlob(DepthFilter::kNone, width, height), true, ColorCodec::kNone, width, height},
      {"depth row-delta", depthBlob(DepthFilter::kRowDelta, width, height), true, ColorCodec::kNone, width,
       height},
      {"depth rank-med", depthBlob(DepthFilter::kRankMed, width, height), true, ColorCodec::kNone, width,
       height},
      {"depth rank-ctx", depthBlob(DepthFilter::kRankCtx, width, height), true, ColorCodec::kNone, width,
       height},
      {"colour jpeg", colorBlob(ColorCodec::kJpeg, width, height), false, ColorCodec::kJpeg, width, height},
      {"colour lossless", colorBlob(ColorCodec::kLossless, width, height), false, ColorCodec::kLossless,
       width, height}};
}

/// One random corruption: bit flips, byte overwrites, truncation, extension, a forged header field, or a
/// range deleted from or inserted into the payload.
Bytes mutate(Bytes b, std::mt19937& rng) {
  auto below = [&](size_t n) { return n == 0 ? size_t{0} : static_cast<size_t>(rng() % n); };
  switch (rng() % 6) {
    case 0:
      for (int i = 0, n = 1 + static_cast<int>(below(4)); i < n; ++i) b[below(b.size())] ^= 1u << below(8);
      break;
    case 1:
      for (int i = 0, n = 1 + static_cast<int>(below(8)); i < n; ++i)
        b[below(b.size())] = static_cast<uint8_t>(rng());
      break;
    case 2:
      b.resize(below(b.size()));
      break;
    case 3:
      for (int i = 0, n = 1 + static_cast<int>(below(64)); i < n; ++i)
        b.push_back(static_cast<uint8_t>(rng()));
      break;
    case 4: {
      const size_t offsets[] = {4, 5, 6, 8, 10, 12, 14};
      const uint16_t values[] = {0, 1, 2, 0xFFFF, 4096, 4097, static_cast<uint16_t>(rng())};
      const size_t at = offsets[below(7)];
      const uint16_t old = static_cast<uint16_t>(b[at] | (b[at + 1] << 8));
      putU16(b, at, below(3) == 0 ? static_cast<uint16_t>(old + (below(2) ? 1 : -1)) : values[below(7)]);
      break;
    }
    default: {
      const size_t at = kImageBlobHeaderSize + below(b.size() - kImageBlobHeaderSize);
      const size_t n = 1 + below(32);
      if (below(2)) {
        b.erase(b.begin() + static_cast<long>(at), b.begin() + static_cast<long>(std::min(b.size(), at + n)));
      } else {
        b.insert(b.begin() + static_cast<long>(at), n, static_cast<uint8_t>(rng()));
      }
    }
  }
  return b;
}

/// Decodes `blob`; fine when it fails with a reason or yields an image of exactly the expected size.
::testing::AssertionResult decodesSafely(const Sample& s, const Bytes& blob, bool* accepted) {
  const auto r = s.is_depth ? decodeDepth(blob.data(), blob.size(), s.width, s.height)
                            : decodeColor(blob.data(), blob.size(), s.codec, s.width, s.height);
  *accepted = r.ok();
  if (!r) {
    if (r.error().empty()) return ::testing::AssertionFailure() << "rejected without a reason";
    return ::testing::AssertionSuccess();
  }
  const int type = s.is_depth ? CV_16UC1 : CV_8UC3;
  if (r->cols != s.width || r->rows != s.height || r->type() != type)
    return ::testing::AssertionFailure()
           << "accepted as " << r->cols << "x" << r->rows << " type " << r->type();
  return ::testing::AssertionSuccess();
}

void fuzz(const std::vector<Sample>& all, int iterations, bool forge_checksum, uint32_t seed) {
  std::mt19937 rng(seed);
  for (const Sample& s : all) {
    int accepted_count = 0;
    for (int i = 0; i < iterations; ++i) {
      Bytes blob = mutate(s.blob, rng);
      if (forge_checksum) reseal(blob, /*keep_length=*/rng() % 4 == 0);
      bool accepted = false;
      ASSERT_TRUE(decodesSafely(s, blob, &accepted)) << s.name << " iteration " << i;
      // Without a forged checksum, every blob that differs from the original must be caught.
      if (!forge_checksum && blob != s.blob) {
        ASSERT_FALSE(accepted) << s.name << " iteration " << i;
      }
      accepted_count += accepted;
    }
    ::testing::Test::RecordProperty(s.name + (forge_checksum ? " forged accepted" : " accepted"),
                                    accepted_count);
  }
}

TEST(ImageBlobCorruption, RandomMutationsAreAllRejected) { fuzz(samples(kW, kH), 2000, false, 1234); }

TEST(ImageBlobCorruption, MutationsWithForgedChecksumDecodeToErrorOrValidImage) {
  fuzz(samples(kW, kH), 2000, true, 5678);
  fuzz(samples(31, 1), 300, true, 91011);
}

TEST(ImageBlobCorruption, FullSizeMutationsWithForgedChecksum) { fuzz(samples(640, 480), 60, true, 1213); }

}  // namespace
}  // namespace rgbdmap
