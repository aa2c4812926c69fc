#pragma once
// Keyframe image codec: lossless depth (context-modelled range coding, or a prefilter + zstd) and colour
// (JPEG, lossless, or omitted).
//
// Every encoded image is a self-describing blob: a 20-byte header followed by the payload. All integers
// are little-endian and written byte by byte (no struct memcpy).
//
//   offset size field
//   0      4    magic: "RDMD" for depth, "RDMC" for colour
//   4      1    format version (kImageBlobVersion)
//   5      1    method: depth -> DepthFilter id, colour -> ColorCodec id (kJpeg or kLossless)
//   6      2    width  in pixels, 1..kMaxImageSide
//   8      2    height in pixels, 1..kMaxImageSide
//   10     2    aux: depth kRankMed, kRankCtx -> number of table entries K (0..32768); otherwise 0
//   12     4    payload length in bytes; must equal blob size - 20 exactly
//   16     4    CRC-32 (zlib's, IEEE polynomial) of bytes 0..15 followed by the payload
//   20     ...  payload
//
// Payloads. Every zstd payload (all but depth kRankCtx) is exactly one frame that declares its content size,
// which must equal the length stated here exactly.
//   depth kNone      zstd(W*H uint16 LE)                                              content 2*W*H
//   depth kRowDelta  zstd(high bytes, then low bytes, of zigzag(v - left))            content 2*W*H
//                    (left of column 0 is the pixel above; above row 0 it is 0)
//   depth kRankMed   zstd(table, then high bytes, then low bytes, of the symbols)     content 2*K + 2*W*H
//                    table: the K distinct non-zero depths ascending, as uint16 LE deltas (first entry
//                    is the value itself); symbol: 0 for a hole (depth 0), otherwise
//                    1 + zigzag(rank - prediction), rank = index in the table. With a, b, c the ranks
//                    left, above, above-left and `last` the rank of the previous pixel with depth in
//                    scan order (0 at first), the prediction is median(a, b, a + b - c) (LOCO-I MED)
//                    when a, b, c all have depth; b when a is a hole or outside and b has depth;
//                    otherwise `last`
//   depth kRankCtx   one adaptive binary range-coded stream (LZMA's coder: 11-bit probabilities, 32-bit
//                    range, carry via a cached byte; probabilities start at 1/2 and adapt at rate 1/2,
//                    1/4, ... settling at 1/32), ending exactly where the payload ends: the K table
//                    entries (the first value minus one, then each step minus one, in adaptive
//                    Elias-gamma), then per pixel in scan order a hole flag and, for a pixel with depth,
//                    its rank residual against the kRankMed prediction (with the above-right rank as a
//                    further fallback). The context models and binarisation are defined by
//                    common/codec/src/depth_context.cpp, which both sides run; the version byte changes with
//                    them
//   zigzag           0, -1, 1, -2, 2, ... -> 0, 1, 2, 3, 4, ...
//   colour kJpeg     baseline Huffman-coded JPEG, 3 components, YCbCr (written 4:2:0); the decoder refuses
//                    progressive and arithmetic-coded JPEGs and treats libjpeg warnings as errors
//   colour kLossless zstd(B plane, G plane, R plane of (v - left) mod 256)            content 3*W*H
//   colour kNone     no blob at all (size 0)
//
// Decoders treat the bytes as untrusted: any inconsistency is an error with a reason, never a crash,
// and nothing is allocated from a size that has not been checked against the expected dimensions. The
// CRC turns accidental corruption into an error; a blob forged with a valid CRC still decodes only to an
// error or to an image of the expected size.
//
// Every function is reentrant (no shared state, safe from any thread), never prints, and reports failure
// as a Result error. cv::setNumThreads is left to the application.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"

namespace rgbdmap {

constexpr uint8_t kImageBlobVersion = 1;
constexpr size_t kImageBlobHeaderSize = 20;
constexpr int kMaxImageSide = 4096;  ///< largest width or height either codec accepts

enum class ColorCodec : uint8_t { kNone = 0, kJpeg = 1, kLossless = 2 };

/// Depth coding. kRankCtx (the default) range-codes the rank residuals of kRankMed with context models:
/// on TUM fr1 frames 31 KB mean against 60 KB for kRankMed + zstd, at 4-5 ms per frame each way on one
/// core (bench_codec). Kinect-style depth takes only a few hundred distinct values per frame; both rank
/// filters fall back to kRowDelta + zstd when a frame has more than 32768 distinct non-zero values. kNone,
/// kRowDelta and kRankMed exist for comparison and as fallbacks, and old blobs of each still decode.
enum class DepthFilter : uint8_t { kNone = 0, kRowDelta = 1, kRankMed = 2, kRankCtx = 3 };

struct ImageCodecOptions {
  ColorCodec color = ColorCodec::kJpeg;
  /// 1..100. The server extracts the keyframe's ORB features from the decoded colour unless the robot
  /// sends its own (link.send_features), and colours the map with it. Measured on fr1_rpy through the
  /// whole system with server-side features (rgbdmap run, 83 keyframes): q60 ATE 0.0151 m at 22 KB colour,
  /// q70 0.0151 m at 26 KB, q75 0.0148 m at 28 KB, q90 (budget-limited) 0.0147 m at 31 KB; robot-sent
  /// features 0.0148 m. Differences of 0.3 mm are within run-to-run spread.
  int jpeg_quality = 70;
  /// encodeImages only: when depth + JPEG colour exceed this many bytes, the colour is re-encoded at
  /// jpeg_quality - 5, - 10, ... down to min_jpeg_quality, and the last try is kept even if it is still
  /// over. 0 turns the budget off. It bounds the largest keyframes (heavily textured or noisy frames).
  size_t max_keyframe_bytes = 64000;
  int min_jpeg_quality = 50;  ///< 1..100
  DepthFilter depth_filter = DepthFilter::kRankCtx;
  int zstd_level = 1;  ///< 1..19, for zstd-coded depth and lossless colour
};

/// The images of one keyframe as sent over the network. `color` is empty when color_codec is kNone.
struct EncodedImages {
  uint16_t width = 0;
  uint16_t height = 0;
  ColorCodec color_codec = ColorCodec::kNone;
  std::vector<uint8_t> depth;
  std::vector<uint8_t> color;
};

struct DecodedImages {
  cv::Mat depth;  ///< CV_16UC1, raw sensor units
  cv::Mat color;  ///< CV_8UC3 BGR; empty when the colour was omitted
};

/// `depth16` must be CV_16UC1 with 1..kMaxImageSide columns and rows (it need not be continuous).
Result<std::vector<uint8_t>> encodeDepth(const cv::Mat& depth16, const ImageCodecOptions& options = {});
/// Decodes a depth blob and checks that it is exactly expected_width x expected_height.
Result<cv::Mat> decodeDepth(const uint8_t* data, size_t size, int expected_width, int expected_height);

/// `bgr` must be CV_8UC3. With options.color == kNone the result is an empty blob.
Result<std::vector<uint8_t>> encodeColor(const cv::Mat& bgr, const ImageCodecOptions& options = {});
/// Decodes a colour blob made with `codec` (which the blob header must confirm) of the expected size.
/// For kNone the blob must be empty and the result is an empty Mat.
Result<cv::Mat> decodeColor(const uint8_t* data, size_t size, ColorCodec codec, int expected_width,
                            int expected_height);

/// Encodes a frame's depth and (unless options.color is kNone) colour; they must have the same size. JPEG
/// colour is fitted to options.max_keyframe_bytes as described there.
Result<EncodedImages> encodeImages(const RgbdFrame& frame, const ImageCodecOptions& options = {});
/// Decodes both blobs against the declared width, height and colour codec.
Result<DecodedImages> decodeImages(const EncodedImages& encoded);

std::string toString(ColorCodec codec);
std::string toString(DepthFilter filter);

}  // namespace rgbdmap
