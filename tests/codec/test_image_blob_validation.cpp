// Forged blobs: each inconsistency is rejected with a reason that names it. Most forgeries recompute the
// checksum (reseal) so that the check behind it is the one exercised.
#include <gtest/gtest.h>
#include <zstd.h>

#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "codec/image_codec_test_util.hpp"
#include "rgbdmap/codec/image_codec.hpp"

namespace rgbdmap {
namespace {

using testing::Bytes;
using testing::putU16;
using testing::reseal;

constexpr int kValW = 32, kValH = 24;

Bytes depthBlob(DepthFilter filter, int height = kValH) { return testing::depthBlob(filter, kValW, height); }
Bytes colorBlob(ColorCodec codec, int height = kValH) { return testing::colorBlob(codec, kValW, height); }

Bytes setByte(Bytes b, size_t at, uint8_t value, bool seal = true) {
  b[at] = value;
  if (seal) reseal(b);
  return b;
}

Bytes setU16(Bytes b, size_t at, uint16_t value) {
  putU16(b, at, value);
  reseal(b);
  return b;
}

Bytes resized(Bytes b, size_t size, bool seal) {
  b.resize(size, 7);
  if (seal) reseal(b);
  return b;
}

Bytes withPayload(Bytes blob, const Bytes& payload) {
  blob.resize(kImageBlobHeaderSize);
  blob.insert(blob.end(), payload.begin(), payload.end());
  reseal(blob);
  return blob;
}

Bytes payloadOf(const Bytes& blob) { return Bytes(blob.begin() + kImageBlobHeaderSize, blob.end()); }

Bytes zstdFrame(const Bytes& content, bool declare_size = true) {
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, declare_size ? 1 : 0);
  Bytes out(ZSTD_compressBound(content.size()));
  out.resize(ZSTD_compress2(cctx, out.data(), out.size(), content.data(), content.size()));
  ZSTD_freeCCtx(cctx);
  return out;
}

/// A kRankMed blob with the given table (as deltas) and every symbol equal to `symbol`.
Bytes forgedRankBlob(const std::vector<uint16_t>& table_deltas, uint16_t symbol) {
  const size_t k = table_deltas.size(), n = kValW * kValH;
  Bytes content(2 * k + 2 * n);
  for (size_t t = 0; t < k; ++t) putU16(content, 2 * t, table_deltas[t]);
  for (size_t i = 0; i < n; ++i) {
    content[2 * k + i] = static_cast<uint8_t>(symbol >> 8);
    content[2 * k + n + i] = static_cast<uint8_t>(symbol & 0xFF);
  }
  Bytes blob = depthBlob(DepthFilter::kRankMed);
  putU16(blob, 10, static_cast<uint16_t>(k));
  return withPayload(blob, zstdFrame(content));
}

Bytes jpegBytes(const cv::Mat& image, const std::vector<int>& params = {}) {
  std::vector<uint8_t> out;
  cv::imencode(".jpg", image, out, params);
  return out;
}

struct Case {
  const char* name;
  Bytes blob;
  const char* expect;  ///< part of the reason
};

void expectDepthRejected(const std::vector<Case>& cases) {
  for (const Case& c : cases) {
    const auto r = decodeDepth(c.blob.data(), c.blob.size(), kValW, kValH);
    ASSERT_FALSE(r) << c.name;
    EXPECT_NE(r.error().find(c.expect), std::string::npos) << c.name << ": " << r.error();
  }
}

void expectColorRejected(ColorCodec codec, const std::vector<Case>& cases) {
  for (const Case& c : cases) {
    const auto r = decodeColor(c.blob.data(), c.blob.size(), codec, kValW, kValH);
    ASSERT_FALSE(r) << c.name;
    EXPECT_NE(r.error().find(c.expect), std::string::npos) << c.name << ": " << r.error();
  }
}

TEST(ImageBlobValidation, ForgedHeadersAreRejectedWithAReason) {
  const Bytes rank = depthBlob(DepthFilter::kRankMed);
  expectDepthRejected({
      {"empty", {}, "shorter than its header"},
      {"short", resized(rank, 10, false), "shorter than its header"},
      {"magic", setByte(rank, 0, 'X'), "bad magic"},
      {"colour blob", colorBlob(ColorCodec::kJpeg), "bad magic"},
      {"version", setByte(rank, 4, 2), "format version 2"},
      {"length", setByte(rank, 12, static_cast<uint8_t>(rank[12] + 1), false), "-byte payload, has"},
      {"extended", resized(rank, rank.size() + 1, false), "-byte payload, has"},
      {"truncated", resized(rank, rank.size() - 1, false), "-byte payload, has"},
      {"bit flip", setByte(rank, 30, static_cast<uint8_t>(rank[30] ^ 4), false), "checksum mismatch"},
      {"width", setU16(rank, 6, kValW + 1), "declares 33x24, expected 32x24"},
      {"zero height", setU16(rank, 8, 0), "outside 1..4096"},
      {"huge width", setU16(rank, 6, 65535), "outside 1..4096"},
  });
  EXPECT_FALSE(decodeDepth(rank.data(), rank.size(), 5000, kValH));  // expected size itself out of range
  EXPECT_FALSE(decodeDepth(rank.data(), rank.size(), kValW, 0));
}

TEST(ImageBlobValidation, ForgedDepthPayloadsAreRejectedWithAReason) {
  const Bytes rank = depthBlob(DepthFilter::kRankMed), none = depthBlob(DepthFilter::kNone);
  expectDepthRejected({
      {"filter", setByte(rank, 5, 9), "unknown filter 9"},
      {"aux huge", setU16(rank, 10, 40000), "bad aux field 40000"},
      {"aux on none", setU16(none, 10, 1), "bad aux field 1 for filter none"},
      {"aux + 1", setU16(rank, 10, static_cast<uint16_t>(rank[10] + 1)), "content bytes, expected"},
      {"garbage", withPayload(rank, Bytes(100, 0x5A)), "not a zstd frame"},
      {"trailing", resized(rank, rank.size() + 3, true), "3 bytes after the frame"},
      {"cut frame", resized(rank, rank.size() - 3, true), "zstd:"},
      {"no size", withPayload(none, zstdFrame(Bytes(2 * kValW * kValH, 1), false)),
       "does not declare its content size"},
      {"other size", withPayload(none, zstdFrame(Bytes(2 * kValW * kValH + 2, 1))),
       "content bytes, expected"},
      {"table order", forgedRankBlob({500, 0}, 0), "not strictly ascending"},
      {"table wrap", forgedRankBlob({60000, 6000}, 0), "not strictly ascending"},
      {"symbol", forgedRankBlob({500}, 5), "row 0 points outside the rank table"},
  });
}

TEST(ImageBlobValidation, ForgedRangeCodedDepthIsRejectedWithAReason) {
  const Bytes ctx = depthBlob(DepthFilter::kRankCtx);
  ASSERT_EQ(ctx[5], static_cast<uint8_t>(DepthFilter::kRankCtx));
  expectDepthRejected({
      {"cut", resized(ctx, ctx.size() - 4, true), "bytes early"},
      {"trailing", resized(ctx, ctx.size() + 3, true), "3 bytes after the coded stream"},
      {"empty", withPayload(ctx, Bytes()), "ends early, in the rank table"},
      {"aux huge", setU16(ctx, 10, 40000), "bad aux field 40000"},
      {"ones", withPayload(ctx, Bytes(64, 0xFF)), "depth blob:"},
  });
}

TEST(ImageBlobValidation, ForgedColourPayloadsAreRejectedWithAReason) {
  const Bytes jpeg = colorBlob(ColorCodec::kJpeg), lossless = colorBlob(ColorCodec::kLossless);
  expectColorRejected(
      ColorCodec::kJpeg,
      {
          {"depth blob", depthBlob(DepthFilter::kRankMed), "bad magic"},
          {"lossless blob", lossless, "codec 2, expected jpeg"},
          {"aux", setByte(jpeg, 10, 1), "non-zero aux"},
          {"cut", resized(jpeg, jpeg.size() / 2, true), "JPEG decode"},
          {"garbage", withPayload(jpeg, Bytes(300, 0x5A)), "JPEG decode: Not a JPEG file"},
          {"jpeg size", withPayload(jpeg, jpegBytes(testing::syntheticColor(kValW, kValH + 1, 1))),
           "JPEG dimensions differ"},
          {"grey", withPayload(jpeg, jpegBytes(cv::Mat(kValH, kValW, CV_8UC1, cv::Scalar(9)))),
           "not 3-component"},
          {"progressive",
           withPayload(
               jpeg, jpegBytes(testing::syntheticColor(kValW, kValH, 1), {cv::IMWRITE_JPEG_PROGRESSIVE, 1})),
           "progressive"},
      });
  expectColorRejected(
      ColorCodec::kLossless,
      {
          {"jpeg blob", jpeg, "codec 1, expected lossless"},
          {"other size", withPayload(lossless, payloadOf(colorBlob(ColorCodec::kLossless, kValH + 1))),
           "content bytes, expected"},
      });
  const uint8_t stray[] = {1};
  EXPECT_FALSE(decodeColor(stray, sizeof(stray), ColorCodec::kNone, kValW, kValH));
}

}  // namespace
}  // namespace rgbdmap
