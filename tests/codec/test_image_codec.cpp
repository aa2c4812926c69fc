#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "codec/image_codec_test_util.hpp"
#include "rgbdmap/codec/image_codec.hpp"
#include "test_data.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::Bytes;
using testing::identical;

const DepthFilter kAllFilters[] = {DepthFilter::kNone, DepthFilter::kRowDelta, DepthFilter::kRankMed,
                                   DepthFilter::kRankCtx};

Result<cv::Mat> depthRoundTrip(const cv::Mat& depth, DepthFilter filter, Bytes* blob_out = nullptr) {
  ImageCodecOptions options;
  options.depth_filter = filter;
  const auto blob = encodeDepth(depth, options);
  if (!blob) return Result<cv::Mat>::failure(blob.error());
  if (blob_out) *blob_out = *blob;
  return decodeDepth(blob->data(), blob->size(), depth.cols, depth.rows);
}

TEST(DepthCodec, LosslessRoundTripOnSyntheticAndRandomImages) {
  const cv::Size sizes[] = {{1, 1}, {2, 3}, {17, 9}, {641, 479}, {640, 480}};
  for (const cv::Size& size : sizes) {
    std::vector<cv::Mat> images = {
        testing::syntheticDepth(size.width, size.height, 1), testing::randomDepth(size.width, size.height, 2),
        testing::randomDepth(size.width, size.height, 3, 40), cv::Mat(size, CV_16UC1, cv::Scalar(0)),
        cv::Mat(size, CV_16UC1, cv::Scalar(65535))};
    for (const cv::Mat& depth : images) {
      for (DepthFilter filter : kAllFilters) {
        const auto decoded = depthRoundTrip(depth, filter);
        ASSERT_TRUE(decoded) << decoded.error();
        EXPECT_TRUE(identical(*decoded, depth)) << size << " " << toString(filter);
      }
    }
  }
}

TEST(DepthCodec, RankFiltersFallBackToRowDeltaWithTooManyDistinctValues) {
  cv::Mat depth(300, 300, CV_16UC1);
  for (int i = 0; i < 300 * 300; ++i)
    depth.at<uint16_t>(i / 300, i % 300) = static_cast<uint16_t>(1 + (i * 7) % 65535);
  for (DepthFilter filter : {DepthFilter::kRankMed, DepthFilter::kRankCtx}) {
    Bytes blob;
    const auto decoded = depthRoundTrip(depth, filter, &blob);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_TRUE(identical(*decoded, depth));
    EXPECT_EQ(blob[5], static_cast<uint8_t>(DepthFilter::kRowDelta)) << toString(filter);
  }
}

// Large jumps (edges far beyond the unary part of the residual code) and a table whose steps need the
// escape code: every residual magnitude path of kRankCtx round-trips.
TEST(DepthCodec, RankCtxRoundTripsLargeResidualsAndSparseTables) {
  cv::Mat depth(64, 80, CV_16UC1, cv::Scalar(0));
  std::mt19937 rng(7);
  const uint16_t values[] = {1, 2, 900, 901, 20000, 20001, 20003, 65000, 65535};
  for (int y = 0; y < depth.rows; ++y)
    for (int x = 0; x < depth.cols; ++x)
      if (rng() % 5 != 0) depth.at<uint16_t>(y, x) = values[(x / 7 + y / 5 + rng() % 2) % 9];
  Bytes blob;
  const auto decoded = depthRoundTrip(depth, DepthFilter::kRankCtx, &blob);
  ASSERT_TRUE(decoded) << decoded.error();
  EXPECT_TRUE(identical(*decoded, depth));
  EXPECT_EQ(blob[5], static_cast<uint8_t>(DepthFilter::kRankCtx));
}

TEST(DepthCodec, AcceptsNonContinuousInput) {
  const cv::Mat big = testing::syntheticDepth(100, 80, 4);
  const cv::Mat roi = big(cv::Rect(7, 5, 61, 33));
  ASSERT_FALSE(roi.isContinuous());
  for (DepthFilter filter : kAllFilters) {
    const auto decoded = depthRoundTrip(roi, filter);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_TRUE(identical(*decoded, roi));
  }
}

TEST(DepthCodec, RejectsBadInputAndOptions) {
  EXPECT_FALSE(encodeDepth(cv::Mat(4, 4, CV_32FC1, cv::Scalar(1.0f))));
  EXPECT_FALSE(encodeDepth(cv::Mat()));
  EXPECT_FALSE(encodeDepth(cv::Mat(1, kMaxImageSide + 1, CV_16UC1, cv::Scalar(1))));
  ImageCodecOptions options;
  options.zstd_level = 0;
  EXPECT_FALSE(encodeDepth(cv::Mat(4, 4, CV_16UC1, cv::Scalar(1)), options));
  options = {};
  options.depth_filter = static_cast<DepthFilter>(7);
  EXPECT_FALSE(encodeDepth(cv::Mat(4, 4, CV_16UC1, cv::Scalar(1)), options));
}

Result<cv::Mat> colorRoundTrip(const cv::Mat& bgr, const ImageCodecOptions& options,
                               size_t* bytes = nullptr) {
  const auto blob = encodeColor(bgr, options);
  if (!blob) return Result<cv::Mat>::failure(blob.error());
  if (bytes) *bytes = blob->size();
  return decodeColor(blob->data(), blob->size(), options.color, bgr.cols, bgr.rows);
}

TEST(ColorCodec, JpegRoundTripWithinPsnrBound) {
  const cv::Mat bgr = testing::syntheticColor(320, 240, 5);
  ImageCodecOptions options;
  size_t previous_bytes = 0;
  double previous_psnr = 0.0;
  for (const auto& [quality, min_psnr] : {std::pair{75, 34.0}, std::pair{90, 36.0}, std::pair{95, 36.5}}) {
    options.jpeg_quality = quality;
    size_t bytes = 0;
    const auto decoded = colorRoundTrip(bgr, options, &bytes);
    ASSERT_TRUE(decoded) << decoded.error();
    ASSERT_EQ(decoded->size(), bgr.size());
    ASSERT_EQ(decoded->type(), CV_8UC3);
    const double psnr = cv::PSNR(*decoded, bgr);
    EXPECT_GT(psnr, min_psnr) << "quality " << quality;
    EXPECT_GT(psnr, previous_psnr) << "quality " << quality;
    EXPECT_GT(bytes, previous_bytes) << "quality " << quality;
    previous_bytes = bytes;
    previous_psnr = psnr;
  }
  const auto odd = colorRoundTrip(testing::syntheticColor(33, 17, 6), options);  // not a multiple of the MCU
  ASSERT_TRUE(odd) << odd.error();
  EXPECT_EQ(odd->size(), cv::Size(33, 17));
}

TEST(ColorCodec, LosslessIsExact) {
  ImageCodecOptions options;
  options.color = ColorCodec::kLossless;
  const cv::Mat roi = testing::randomColor(50, 40, 8)(cv::Rect(3, 2, 41, 29));
  for (const cv::Mat& bgr : {testing::syntheticColor(640, 480, 7), testing::randomColor(1, 1, 9), roi}) {
    const auto decoded = colorRoundTrip(bgr, options);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_TRUE(identical(*decoded, bgr));
  }
}

TEST(ColorCodec, NoneModeCarriesNothing) {
  ImageCodecOptions options;
  options.color = ColorCodec::kNone;
  const auto blob = encodeColor(testing::syntheticColor(16, 8, 10), options);
  ASSERT_TRUE(blob) << blob.error();
  EXPECT_TRUE(blob->empty());
  const auto decoded = decodeColor(nullptr, 0, ColorCodec::kNone, 16, 8);
  ASSERT_TRUE(decoded) << decoded.error();
  EXPECT_TRUE(decoded->empty());
  const uint8_t stray[] = {1, 2, 3};
  EXPECT_FALSE(decodeColor(stray, sizeof(stray), ColorCodec::kNone, 16, 8));
}

TEST(ColorCodec, RejectsBadInputAndOptions) {
  EXPECT_FALSE(encodeColor(cv::Mat(4, 4, CV_8UC1, cv::Scalar(1))));
  EXPECT_FALSE(encodeColor(cv::Mat()));
  ImageCodecOptions options;
  options.jpeg_quality = 101;
  EXPECT_FALSE(encodeColor(testing::syntheticColor(8, 8, 11), options));
  options = {};
  options.color = static_cast<ColorCodec>(3);
  EXPECT_FALSE(encodeColor(testing::syntheticColor(8, 8, 11), options));
  EXPECT_FALSE(decodeColor(nullptr, 0, static_cast<ColorCodec>(3), 8, 8));
}

TEST(ImageCodec, KeyframeRoundTripEveryColourMode) {
  RgbdFrame frame;
  frame.depth = testing::syntheticDepth(64, 48, 12);
  frame.color = testing::syntheticColor(64, 48, 13);
  for (ColorCodec codec : {ColorCodec::kNone, ColorCodec::kJpeg, ColorCodec::kLossless}) {
    ImageCodecOptions options;
    options.color = codec;
    const auto encoded = encodeImages(frame, options);
    ASSERT_TRUE(encoded) << encoded.error();
    EXPECT_EQ(encoded->width, 64);
    EXPECT_EQ(encoded->height, 48);
    EXPECT_EQ(encoded->color_codec, codec);
    const auto decoded = decodeImages(*encoded);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_TRUE(identical(decoded->depth, frame.depth));
    EXPECT_EQ(decoded->color.empty(), codec == ColorCodec::kNone);
    if (codec == ColorCodec::kLossless) {
      EXPECT_TRUE(identical(decoded->color, frame.color));
    }
  }
}

TEST(ImageCodec, ColourAndDepthSizesMustAgree) {
  RgbdFrame frame;
  frame.depth = testing::syntheticDepth(64, 48, 14);
  frame.color = testing::syntheticColor(64, 49, 15);
  const auto encoded = encodeImages(frame);
  ASSERT_FALSE(encoded);
  EXPECT_NE(encoded.error().find("differ in size"), std::string::npos) << encoded.error();

  frame.color = testing::syntheticColor(64, 48, 15);
  auto good = encodeImages(frame);
  ASSERT_TRUE(good) << good.error();
  good->color = encodeColor(testing::syntheticColor(64, 49, 15)).value();  // a colour blob of another size
  const auto decoded = decodeImages(*good);
  ASSERT_FALSE(decoded);
  EXPECT_NE(decoded.error().find("expected 64x48"), std::string::npos) << decoded.error();
}

TEST(ImageCodec, JpegColourIsFittedToTheKeyframeBudget) {
  RgbdFrame frame;
  frame.depth = testing::syntheticDepth(320, 240, 16);
  frame.color = testing::randomColor(320, 240, 17);  // noise: large at any quality
  ImageCodecOptions options;
  options.jpeg_quality = 90;  // room for steps above min_jpeg_quality
  options.max_keyframe_bytes = 0;
  const auto unlimited = encodeImages(frame, options);
  ASSERT_TRUE(unlimited) << unlimited.error();
  const size_t full = unlimited->depth.size() + unlimited->color.size();

  options.max_keyframe_bytes = full * 3 / 4;
  const auto fitted = encodeImages(frame, options);
  ASSERT_TRUE(fitted) << fitted.error();
  EXPECT_LE(fitted->depth.size() + fitted->color.size(), options.max_keyframe_bytes);
  EXPECT_EQ(fitted->depth, unlimited->depth);  // depth stays lossless
  ASSERT_TRUE(decodeImages(*fitted));

  options.max_keyframe_bytes = 1000;  // out of reach: the min_jpeg_quality result is kept
  options.min_jpeg_quality = 40;
  const auto floor = encodeImages(frame, options);
  ASSERT_TRUE(floor) << floor.error();
  options.max_keyframe_bytes = 0;
  options.jpeg_quality = 40;
  EXPECT_EQ(floor->color, encodeImages(frame, options)->color);
}

std::vector<std::string> sortedFiles(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

RGBDMAP_TEST_TIER("ImageCodecRealData.*", "e2e sanitize");
// Lossless depth + JPEG colour within the default keyframe image budget (default options: rank-ctx depth,
// JPEG colour stepped down for the frames that would exceed the budget); the range-coded depth of a
// fr1_rpy frame takes 31-37 KB (rank-med + zstd: 55-65 KB).
TEST(ImageCodecRealData, Fr1RpyKeyframesAreLosslessAndWithinTheBudget) {
  RGBDMAP_REQUIRE_SHARED_DATA("tum_fr1_rpy_first250");
  const std::string dir = testing::sharedDataDir("tum_fr1_rpy_first250");
  const auto rgb = sortedFiles(dir + "/rgb"), depth = sortedFiles(dir + "/depth");
  ASSERT_GE(std::min(rgb.size(), depth.size()), 241u);
  for (size_t i = 0; i <= 240; i += 60) {
    RgbdFrame frame;
    frame.color = cv::imread(rgb[i], cv::IMREAD_COLOR);
    frame.depth = cv::imread(depth[i], cv::IMREAD_UNCHANGED);
    ASSERT_EQ(frame.depth.type(), CV_16UC1) << depth[i];
    const ImageCodecOptions defaults;
    const auto encoded = encodeImages(frame, defaults);
    ASSERT_TRUE(encoded) << encoded.error();
    EXPECT_EQ(encoded->depth[5], static_cast<uint8_t>(DepthFilter::kRankCtx));
    EXPECT_LE(encoded->depth.size(), 42000u) << "frame " << i;
    const size_t bytes = encoded->depth.size() + encoded->color.size();
    EXPECT_LE(bytes, defaults.max_keyframe_bytes)
        << "frame " << i << ": depth " << encoded->depth.size() << " colour " << encoded->color.size();
    const auto decoded = decodeImages(*encoded);
    ASSERT_TRUE(decoded) << decoded.error();
    EXPECT_TRUE(identical(decoded->depth, frame.depth)) << "frame " << i;
    EXPECT_GT(cv::PSNR(decoded->color, frame.color), 29.0) << "frame " << i;
  }
}

}  // namespace
}  // namespace rgbdmap
