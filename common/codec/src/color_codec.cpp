// Colour codec: JPEG (lossy), left-delta planes + zstd (lossless), or nothing; see image_codec.hpp.
#include <string>
#include <vector>

#include "image_blob.hpp"
#include "jpeg_io.hpp"
#include "rgbdmap/codec/image_codec.hpp"

namespace rgbdmap {
namespace {

using detail::BlobKind;
using Bytes = std::vector<uint8_t>;

/// Planes B, G, R of (v - left) mod 256; left of column 0 is the pixel above, above row 0 it is 0.
Bytes packLeftDeltaPlanes(const cv::Mat& bgr) {
  const size_t n = bgr.total();
  Bytes out(3 * n);
  size_t i = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    const uint8_t* row = bgr.ptr<uint8_t>(y);
    const uint8_t* up = y > 0 ? bgr.ptr<uint8_t>(y - 1) : nullptr;
    uint8_t left[3] = {0, 0, 0};
    for (int ch = 0; up != nullptr && ch < 3; ++ch) left[ch] = up[ch];
    for (int x = 0; x < bgr.cols; ++x, ++i) {
      for (int ch = 0; ch < 3; ++ch) {
        const uint8_t v = row[3 * x + ch];
        out[ch * n + i] = static_cast<uint8_t>(v - left[ch]);
        left[ch] = v;
      }
    }
  }
  return out;
}

void unpackLeftDeltaPlanes(const Bytes& in, cv::Mat& bgr) {
  const size_t n = bgr.total();
  size_t i = 0;
  for (int y = 0; y < bgr.rows; ++y) {
    uint8_t* row = bgr.ptr<uint8_t>(y);
    const uint8_t* up = y > 0 ? bgr.ptr<uint8_t>(y - 1) : nullptr;
    uint8_t left[3] = {0, 0, 0};
    for (int ch = 0; up != nullptr && ch < 3; ++ch) left[ch] = up[ch];
    for (int x = 0; x < bgr.cols; ++x, ++i) {
      for (int ch = 0; ch < 3; ++ch) {
        left[ch] = static_cast<uint8_t>(left[ch] + in[ch * n + i]);
        row[3 * x + ch] = left[ch];
      }
    }
  }
}

Status checkColorOptions(const ImageCodecOptions& o) {
  if (o.color != ColorCodec::kNone && o.color != ColorCodec::kJpeg && o.color != ColorCodec::kLossless)
    return Status::failure("unknown colour codec " + std::to_string(static_cast<int>(o.color)));
  if (o.color == ColorCodec::kJpeg && (o.jpeg_quality < 1 || o.jpeg_quality > 100))
    return Status::failure("jpeg_quality " + std::to_string(o.jpeg_quality) + " outside 1..100");
  if (o.color == ColorCodec::kJpeg && (o.min_jpeg_quality < 1 || o.min_jpeg_quality > 100))
    return Status::failure("min_jpeg_quality " + std::to_string(o.min_jpeg_quality) + " outside 1..100");
  if (o.color == ColorCodec::kLossless && (o.zstd_level < 1 || o.zstd_level > 19))
    return Status::failure("zstd_level " + std::to_string(o.zstd_level) + " outside 1..19");
  return Status::success();
}

Status decodePayload(const uint8_t* payload, size_t size, ColorCodec codec, cv::Mat& bgr) {
  if (codec == ColorCodec::kJpeg) return detail::decodeJpegInto(payload, size, bgr);
  const auto content = detail::decompressZstdFrame(payload, size, 3 * bgr.total());
  if (!content) return Status::failure(content.error());
  unpackLeftDeltaPlanes(*content, bgr);
  return Status::success();
}

}  // namespace

Result<Bytes> encodeColor(const cv::Mat& bgr, const ImageCodecOptions& options) {
  using R = Result<Bytes>;
  if (const Status s = checkColorOptions(options); !s) return R::failure(s.error());
  if (options.color == ColorCodec::kNone) return Bytes{};
  if (bgr.type() != CV_8UC3) return R::failure("colour must be CV_8UC3");
  if (const Status s = detail::checkImageSize(bgr.cols, bgr.rows, "colour"); !s) return R::failure(s.error());
  Bytes blob;
  detail::beginBlob(BlobKind::kColor,
                    {static_cast<uint8_t>(options.color), static_cast<uint16_t>(bgr.cols),
                     static_cast<uint16_t>(bgr.rows), 0},
                    blob);
  Status s = Status::success();
  if (options.color == ColorCodec::kJpeg) {
    s = detail::appendJpeg(bgr, options.jpeg_quality, blob);
  } else {
    const Bytes planes = packLeftDeltaPlanes(bgr);
    s = detail::appendZstdFrame(planes.data(), planes.size(), options.zstd_level, blob);
  }
  if (s) s = detail::finishBlob(blob);
  if (!s) return R::failure("colour: " + s.error());
  return blob;
}

Result<cv::Mat> decodeColor(const uint8_t* data, size_t size, ColorCodec codec, int expected_width,
                            int expected_height) {
  using R = Result<cv::Mat>;
  if (codec == ColorCodec::kNone) {
    if (size != 0)
      return R::failure("colour blob: " + std::to_string(size) + " bytes where none were expected");
    return cv::Mat();
  }
  if (codec != ColorCodec::kJpeg && codec != ColorCodec::kLossless)
    return R::failure("colour blob: unknown codec " + std::to_string(static_cast<int>(codec)));
  const auto header = detail::parseBlobHeader(data, size, BlobKind::kColor, expected_width, expected_height);
  if (!header) return R::failure(header.error());
  if (header->method != static_cast<uint8_t>(codec))
    return R::failure("colour blob: codec " + std::to_string(header->method) + ", expected " +
                      toString(codec));
  if (header->aux != 0) return R::failure("colour blob: non-zero aux field");
  cv::Mat bgr(header->height, header->width, CV_8UC3);
  const Status s = decodePayload(data + kImageBlobHeaderSize, size - kImageBlobHeaderSize, codec, bgr);
  if (!s) return R::failure("colour blob: " + s.error());
  return bgr;
}

std::string toString(ColorCodec codec) {
  switch (codec) {
    case ColorCodec::kNone:
      return "none";
    case ColorCodec::kJpeg:
      return "jpeg";
    case ColorCodec::kLossless:
      return "lossless";
  }
  return "unknown(" + std::to_string(static_cast<int>(codec)) + ")";
}

}  // namespace rgbdmap
