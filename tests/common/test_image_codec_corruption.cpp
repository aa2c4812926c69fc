// Untrusted blobs: every forged or corrupted blob is rejected with a reason, or (when forged with a valid
// checksum) decodes to an image of exactly the declared size. Never a crash.
#include <gtest/gtest.h>
#include <zstd.h>

#include <functional>
#include <random>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "common/image_codec_test_util.hpp"
#include "rgbdmap/common/image_codec.hpp"

namespace rgbdmap {
namespace {

using testing::Bytes;
using testing::putU16;
using testing::reseal;

constexpr int kW = 32, kH = 24;

Bytes depthBlob(DepthFilter filter, int width = kW, int height = kH) {
  ImageCodecOptions options;
  options.depth_filter = filter;
  return encodeDepth(testing::syntheticDepth(width, height, 21), options).value();
}

Bytes colorBlob(ColorCodec codec, int width = kW, int height = kH) {
  ImageCodecOptions options;
  options.color = codec;
  return encodeColor(testing::syntheticColor(width, height, 22), options).value();
}

Bytes withPayload(Bytes blob, const Bytes& payload) {
  blob.resize(kImageBlobHeaderSize);
  blob.insert(blob.end(), payload.begin(), payload.end());
  reseal(blob);
  return blob;
}

Bytes zstdFrame(const Bytes& content, bool declare_size = true) {
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, declare_size ? 1 : 0);
  Bytes out(ZSTD_compressBound(content.size()));
  out.resize(ZSTD_compress2(cctx, out.data(), out.size(), content.data(), content.size()));
  ZSTD_freeCCtx(cctx);
  return out;
}

Bytes payloadOf(const Bytes& blob) { return Bytes(blob.begin() + kImageBlobHeaderSize, blob.end()); }

/// kRankMed content with a given table (as deltas) and every symbol equal to `symbol`.
Bytes rankContent(const std::vector<uint16_t>& table_deltas, uint16_t symbol) {
  Bytes content(2 * table_deltas.size() + 2 * kW * kH);
  for (size_t t = 0; t < table_deltas.size(); ++t) putU16(content, 2 * t, table_deltas[t]);
  const size_t planes = 2 * table_deltas.size(), n = kW * kH;
  for (size_t i = 0; i < n; ++i) {
    content[planes + i] = static_cast<uint8_t>(symbol >> 8);
    content[planes + n + i] = static_cast<uint8_t>(symbol & 0xFF);
  }
  return content;
}

Bytes forgedRankBlob(const std::vector<uint16_t>& table_deltas, uint16_t symbol) {
  Bytes blob = depthBlob(DepthFilter::kRankMed);
  putU16(blob, 10, static_cast<uint16_t>(table_deltas.size()));
  return withPayload(blob, zstdFrame(rankContent(table_deltas, symbol)));
}

Bytes jpegBytes(const cv::Mat& image, std::vector<int> params) {
  std::vector<uint8_t> out;
  cv::imencode(".jpg", image, out, params);
  return out;
}

struct Case {
  std::string name;
  std::function<Bytes()> make;
  bool is_depth;
  ColorCodec codec;
  std::string expect;
};

TEST(ImageBlob, ForgedBlobsAreRejectedWithAReason) {
  const Bytes rank = depthBlob(DepthFilter::kRankMed), none = depthBlob(DepthFilter::kNone);
  const Bytes jpeg = colorBlob(ColorCodec::kJpeg), lossless = colorBlob(ColorCodec::kLossless);
  auto edit = [](Bytes b, const std::function<void(Bytes&)>& f, bool seal) {
    f(b);
    if (seal) reseal(b);
    return b;
  };
  const ColorCodec J = ColorCodec::kJpeg, L = ColorCodec::kLossless, N = ColorCodec::kNone;
  const std::vector<Case> cases = {
      {"short", [&] { return Bytes(rank.begin(), rank.begin() + 10); }, true, N, "shorter than its header"},
      {"magic",
       [&] {
         return edit(
             rank, [](Bytes& b) { b[0] = 'X'; }, true);
       },
       true, N, "bad magic"},
      {"colour as depth", [&] { return jpeg; }, true, N, "bad magic"},
      {"version",
       [&] {
         return edit(
             rank, [](Bytes& b) { b[4] = 2; }, true);
       },
       true, N, "format version 2"},
      {"length",
       [&] {
         return edit(
             rank, [](Bytes& b) { ++b[12]; }, false);
       },
       true, N, "-byte payload, has"},
      {"extended",
       [&] {
         return edit(
             rank, [](Bytes& b) { b.push_back(0); }, false);
       },
       true, N, "-byte payload"},
      {"bit flip",
       [&] {
         return edit(
             rank, [](Bytes& b) { b[30] ^= 4; }, false);
       },
       true, N, "checksum mismatch"},
      {"width",
       [&] {
         return edit(
             rank, [](Bytes& b) { putU16(b, 6, kW + 1); }, true);
       },
       true, N, "declares 33x24, expected 32x24"},
      {"zero height",
       [&] {
         return edit(
             rank, [](Bytes& b) { putU16(b, 8, 0); }, true);
       },
       true, N, "outside 1..4096"},
      {"filter",
       [&] {
         return edit(
             rank, [](Bytes& b) { b[5] = 9; }, true);
       },
       true, N, "unknown filter 9"},
      {"aux huge",
       [&] {
         return edit(
             rank, [](Bytes& b) { putU16(b, 10, 40000); }, true);
       },
       true, N, "bad aux"},
      {"aux on none",
       [&] {
         return edit(
             none, [](Bytes& b) { putU16(b, 10, 1); }, true);
       },
       true, N, "bad aux"},
      {"aux +1",
       [&] {
         return edit(
             rank, [](Bytes& b) { ++b[10]; }, true);
       },
       true, N, "content bytes, expected"},
      {"garbage", [&] { return withPayload(rank, Bytes(100, 0x5A)); }, true, N, "not a zstd frame"},
      {"trailing",
       [&] {
         return edit(
             rank, [](Bytes& b) { b.push_back(7); }, true);
       },
       true, N, "bytes after the frame"},
      {"no size", [&] { return withPayload(none, zstdFrame(Bytes(2 * kW * kH, 1), false)); }, true, N,
       "does not declare its content size"},
      {"table order",
       [&] {
         return forgedRankBlob({500, 0}, 0);
       },
       true, N, "not strictly ascending"},
      {"table wrap",
       [&] {
         return forgedRankBlob({60000, 6000}, 0);
       },
       true, N, "not strictly ascending"},
      {"symbol", [&] { return forgedRankBlob({500}, 5); }, true, N, "outside the rank table"},
      {"depth as colour", [&] { return rank; }, false, J, "bad magic"},
      {"codec", [&] { return jpeg; }, false, L, "codec 1, expected lossless"},
      {"colour aux",
       [&] {
         return edit(
             jpeg, [](Bytes& b) { b[10] = 1; }, true);
       },
       false, J, "non-zero aux"},
      {"jpeg cut",
       [&] {
         return edit(
             jpeg, [](Bytes& b) { b.resize(b.size() / 2); }, true);
       },
       false, J, "JPEG decode"},
      {"jpeg size", [&] { return withPayload(jpeg, jpegBytes(testing::syntheticColor(kW, kH + 1, 1), {})); },
       false, J, "JPEG dimensions differ"},
      {"jpeg gray", [&] { return withPayload(jpeg, jpegBytes(cv::Mat(kH, kW, CV_8UC1, cv::Scalar(9)), {})); },
       false, J, "not 3-component"},
      {"progressive",
       [&] {
         return withPayload(jpeg,
                            jpegBytes(testing::syntheticColor(kW, kH, 1), {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
       },
       false, J, "progressive"},
      {"lossless size", [&] { return withPayload(lossless, payloadOf(colorBlob(L, kW, kH + 1))); }, false, L,
       "content bytes, expected"},
  };
  for (const Case& c : cases) {
    const Bytes blob = c.make();
    const auto result = c.is_depth ? decodeDepth(blob.data(), blob.size(), kW, kH)
                                   : decodeColor(blob.data(), blob.size(), c.codec, kW, kH);
    ASSERT_FALSE(result) << c.name;
    EXPECT_NE(result.error().find(c.expect), std::string::npos) << c.name << ": " << result.error();
  }
  EXPECT_FALSE(decodeDepth(rank.data(), rank.size(), 5000, kH));
  EXPECT_FALSE(decodeDepth(nullptr, 0, kW, kH));
}

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
