#pragma once
// Internal: the reversible depth prefilters applied before zstd (byte layouts in image_codec.hpp).
// Pack functions fill `out` (resized to the content length); unpack functions write into a CV_16UC1
// image that the caller has allocated with the blob's declared size.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::detail {

using Bytes = std::vector<uint8_t>;

/// The rank of a pixel without depth, or outside the image, in the rank filters.
constexpr int kHole = -1;

/// Largest rank table: keeps 1 + zigzag(rank - prediction) within 16 bits.
constexpr size_t kMaxRankTableSize = 32768;

void packRaw(const cv::Mat& depth, Bytes& out);
void unpackRaw(const uint8_t* in, cv::Mat& depth);

void packRowDelta(const cv::Mat& depth, Bytes& out);
void unpackRowDelta(const uint8_t* in, cv::Mat& depth);

/// The distinct non-zero depths of `depth`, ascending.
std::vector<uint16_t> distinctNonZero(const cv::Mat& depth);
/// Content for a table of at most kMaxRankTableSize entries: table deltas, symbol high and low planes.
void packRankMed(const cv::Mat& depth, const std::vector<uint16_t>& table, Bytes& out);
/// `in` holds 2 * table_size + 2 * depth.total() bytes. Fails on a table that is not strictly
/// ascending or a symbol that points outside it.
Status unpackRankMed(const uint8_t* in, size_t table_size, cv::Mat& depth);

/// kRankCtx: the table and every pixel range coded with context models (depth_context.cpp); `out` is the
/// whole payload. A table of at most kMaxRankTableSize entries.
void packRankCtx(const cv::Mat& depth, const std::vector<uint16_t>& table, Bytes& out);
/// Decodes a payload of `size` bytes into `depth` (allocated with the declared size). Fails on a table
/// outside 1..65535, a rank outside the table, or a stream that is shorter or longer than what it codes.
Status unpackRankCtx(const uint8_t* in, size_t size, size_t table_size, cv::Mat& depth);

}  // namespace rgbdmap::detail
