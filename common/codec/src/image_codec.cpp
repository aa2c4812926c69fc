// Keyframe-level wrappers: both images of a frame, encoded and decoded against one declared size.
#include <algorithm>
#include <string>
#include <utility>

#include "rgbdmap/codec/image_codec.hpp"

namespace rgbdmap {
namespace {

constexpr int kJpegQualityStep = 5;

/// Colour blob; JPEG is re-encoded at lower quality until depth + colour fit the keyframe budget.
Result<std::vector<uint8_t>> encodeColorWithinBudget(const cv::Mat& bgr, ImageCodecOptions options,
                                                     size_t depth_bytes) {
  auto color = encodeColor(bgr, options);
  if (!color || options.color != ColorCodec::kJpeg || options.max_keyframe_bytes == 0) return color;
  while (depth_bytes + color->size() > options.max_keyframe_bytes &&
         options.jpeg_quality > options.min_jpeg_quality) {
    options.jpeg_quality = std::max(options.min_jpeg_quality, options.jpeg_quality - kJpegQualityStep);
    color = encodeColor(bgr, options);
    if (!color) break;
  }
  return color;
}

}  // namespace

Result<EncodedImages> encodeImages(const RgbdFrame& frame, const ImageCodecOptions& options) {
  using R = Result<EncodedImages>;
  if (options.color != ColorCodec::kNone && frame.color.size() != frame.depth.size())
    return R::failure("colour " + std::to_string(frame.color.cols) + "x" + std::to_string(frame.color.rows) +
                      " and depth " + std::to_string(frame.depth.cols) + "x" +
                      std::to_string(frame.depth.rows) + " differ in size");
  auto depth = encodeDepth(frame.depth, options);
  if (!depth) return R::failure(depth.error());
  auto color = encodeColorWithinBudget(frame.color, options, depth->size());
  if (!color) return R::failure(color.error());
  EncodedImages out;
  out.width = static_cast<uint16_t>(frame.depth.cols);
  out.height = static_cast<uint16_t>(frame.depth.rows);
  out.color_codec = options.color;
  out.depth = std::move(*depth);
  out.color = std::move(*color);
  return out;
}

Result<DecodedImages> decodeImages(const EncodedImages& encoded) {
  using R = Result<DecodedImages>;
  auto depth = decodeDepth(encoded.depth.data(), encoded.depth.size(), encoded.width, encoded.height);
  if (!depth) return R::failure(depth.error());
  auto color = decodeColor(encoded.color.data(), encoded.color.size(), encoded.color_codec, encoded.width,
                           encoded.height);
  if (!color) return R::failure(color.error());
  return DecodedImages{std::move(*depth), std::move(*color)};
}

}  // namespace rgbdmap
