#pragma once
// Internal: baseline JPEG through libjpeg(-turbo) directly, so that corrupt input is an error (libjpeg
// warnings included) and nothing is printed or allocated from sizes declared inside the JPEG.
#include <cstddef>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap::detail {

/// Appends a baseline YCbCr 4:2:0 JPEG of `bgr` (CV_8UC3) at `quality` (1..100) to `out`.
Status appendJpeg(const cv::Mat& bgr, int quality, std::vector<uint8_t>& out);

/// Decodes a JPEG into `bgr`, which the caller has allocated as CV_8UC3 of the expected size. The JPEG
/// must be a 3-component baseline (non-progressive, Huffman-coded) YCbCr image of exactly that size, and
/// decode without a single libjpeg warning.
Status decodeJpegInto(const uint8_t* data, size_t size, cv::Mat& bgr);

}  // namespace rgbdmap::detail
