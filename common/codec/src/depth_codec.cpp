// Lossless depth codec: a cheap prefilter (depth_filters.hpp; byte layout in image_codec.hpp), then zstd.
#include <string>
#include <vector>

#include "depth_filters.hpp"
#include "image_blob.hpp"
#include "rgbdmap/codec/image_codec.hpp"

namespace rgbdmap {
namespace {

using detail::BlobKind;
using detail::Bytes;

bool knownFilter(DepthFilter f) {
  return f == DepthFilter::kNone || f == DepthFilter::kRowDelta || f == DepthFilter::kRankMed ||
         f == DepthFilter::kRankCtx;
}

Status checkDepthOptions(const ImageCodecOptions& o) {
  if (o.zstd_level < 1 || o.zstd_level > 19)
    return Status::failure("zstd_level " + std::to_string(o.zstd_level) + " outside 1..19");
  if (!knownFilter(o.depth_filter))
    return Status::failure("unknown depth filter " + std::to_string(static_cast<int>(o.depth_filter)));
  return Status::success();
}

/// Runs the requested filter (kRankMed and kRankCtx fall back to kRowDelta + zstd past kMaxRankTableSize
/// distinct values) and records the filter actually used, and the table size, in the header.
DepthFilter filterDepth(const cv::Mat& depth, DepthFilter filter, detail::BlobHeader& header,
                        Bytes& content) {
  if (filter == DepthFilter::kRankMed || filter == DepthFilter::kRankCtx) {
    const std::vector<uint16_t> table = detail::distinctNonZero(depth);
    if (table.size() <= detail::kMaxRankTableSize) {
      header.aux = static_cast<uint16_t>(table.size());
      if (filter == DepthFilter::kRankMed) detail::packRankMed(depth, table, content);
      if (filter == DepthFilter::kRankCtx) detail::packRankCtx(depth, table, content);
    } else {
      filter = DepthFilter::kRowDelta;
    }
  }
  if (filter == DepthFilter::kRowDelta) detail::packRowDelta(depth, content);
  if (filter == DepthFilter::kNone) detail::packRaw(depth, content);
  header.method = static_cast<uint8_t>(filter);
  return filter;
}

}  // namespace

Result<Bytes> encodeDepth(const cv::Mat& depth16, const ImageCodecOptions& options) {
  using R = Result<Bytes>;
  if (depth16.type() != CV_16UC1) return R::failure("depth must be CV_16UC1");
  if (const Status s = detail::checkImageSize(depth16.cols, depth16.rows, "depth"); !s)
    return R::failure(s.error());
  if (const Status s = checkDepthOptions(options); !s) return R::failure(s.error());
  detail::BlobHeader header{0, static_cast<uint16_t>(depth16.cols), static_cast<uint16_t>(depth16.rows), 0};
  Bytes content;
  const DepthFilter used = filterDepth(depth16, options.depth_filter, header, content);
  Bytes blob;
  detail::beginBlob(BlobKind::kDepth, header, blob);
  if (used == DepthFilter::kRankCtx) {
    blob.insert(blob.end(), content.begin(), content.end());  // range coded already
  } else if (Status s = detail::appendZstdFrame(content.data(), content.size(), options.zstd_level, blob);
             !s) {
    return R::failure("depth: " + s.error());
  }
  if (Status s = detail::finishBlob(blob); !s) return R::failure("depth: " + s.error());
  return blob;
}

Result<cv::Mat> decodeDepth(const uint8_t* data, size_t size, int expected_width, int expected_height) {
  using R = Result<cv::Mat>;
  const auto header = detail::parseBlobHeader(data, size, BlobKind::kDepth, expected_width, expected_height);
  if (!header) return R::failure(header.error());
  const DepthFilter filter = static_cast<DepthFilter>(header->method);
  if (!knownFilter(filter)) return R::failure("depth blob: unknown filter " + std::to_string(header->method));
  const size_t n = static_cast<size_t>(header->width) * header->height;
  const bool ranked = filter == DepthFilter::kRankMed || filter == DepthFilter::kRankCtx;
  const size_t k = ranked ? header->aux : 0;
  if (header->aux != k || k > detail::kMaxRankTableSize || k > n)
    return R::failure("depth blob: bad aux field " + std::to_string(header->aux) + " for filter " +
                      toString(filter));
  if (filter == DepthFilter::kRankCtx) {
    cv::Mat depth(header->height, header->width, CV_16UC1);
    if (const Status s =
            detail::unpackRankCtx(data + kImageBlobHeaderSize, size - kImageBlobHeaderSize, k, depth);
        !s)
      return R::failure(s.error());
    return depth;
  }
  const auto content =
      detail::decompressZstdFrame(data + kImageBlobHeaderSize, size - kImageBlobHeaderSize, 2 * k + 2 * n);
  if (!content) return R::failure("depth blob: " + content.error());
  cv::Mat depth(header->height, header->width, CV_16UC1);
  if (filter == DepthFilter::kNone) detail::unpackRaw(content->data(), depth);
  if (filter == DepthFilter::kRowDelta) detail::unpackRowDelta(content->data(), depth);
  if (filter == DepthFilter::kRankMed) {
    if (const Status s = detail::unpackRankMed(content->data(), k, depth); !s) return R::failure(s.error());
  }
  return depth;
}

std::string toString(DepthFilter filter) {
  switch (filter) {
    case DepthFilter::kNone:
      return "none";
    case DepthFilter::kRowDelta:
      return "row-delta";
    case DepthFilter::kRankMed:
      return "rank-med";
    case DepthFilter::kRankCtx:
      return "rank-ctx";
  }
  return "unknown(" + std::to_string(static_cast<int>(filter)) + ")";
}

}  // namespace rgbdmap
