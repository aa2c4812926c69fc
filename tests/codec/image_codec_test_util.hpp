#pragma once
// Test images and blob surgery for the image codec tests. The blob layout is re-implemented here from the
// documentation in image_codec.hpp, so the tests also check that the code matches what it documents.
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "rgbdmap/codec/image_codec.hpp"

namespace rgbdmap::testing {

using Bytes = std::vector<uint8_t>;

inline void putU16(Bytes& b, size_t at, uint16_t v) {
  b[at] = static_cast<uint8_t>(v & 0xFF);
  b[at + 1] = static_cast<uint8_t>(v >> 8);
}

inline void putU32(Bytes& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>((v >> (8 * i)) & 0xFF);
}

/// Recomputes the payload length (unless keep_length) and the CRC, as a forger would.
inline void reseal(Bytes& blob, bool keep_length = false) {
  if (blob.size() < kImageBlobHeaderSize) return;
  if (!keep_length) putU32(blob, 12, static_cast<uint32_t>(blob.size() - kImageBlobHeaderSize));
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, blob.data(), 16);
  crc = crc32(crc, blob.data() + kImageBlobHeaderSize, static_cast<uInt>(blob.size() - kImageBlobHeaderSize));
  putU32(blob, 16, static_cast<uint32_t>(crc));
}

/// Kinect-like depth: quantised slanted planes, a sphere, rectangular and speckle holes, a few max values.
inline cv::Mat syntheticDepth(int width, int height, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  cv::Mat depth(height, width, CV_16UC1);
  const double gx = 0.5 + u(rng), gy = 0.2 * u(rng), cx = width * u(rng), cy = height * u(rng);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double metres = 1.0 + gx * x / width + gy * y / height;
      const double r2 = ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (0.04 * width * width + 1.0);
      if (r2 < 1.0) metres -= 0.3 * std::sqrt(1.0 - r2);
      const double disparity = std::round(1090.0 - 348.0 / metres);  // Kinect-style quantisation
      depth.at<uint16_t>(y, x) = static_cast<uint16_t>(std::round(5000.0 * 348.0 / (1090.0 - disparity)));
    }
  }
  cv::rectangle(depth, cv::Rect(width / 5, height / 3, width / 6 + 1, height / 4 + 1), cv::Scalar(0),
                cv::FILLED);
  for (int i = 0; i < width * height / 20; ++i) depth.at<uint16_t>(rng() % height, rng() % width) = 0;
  for (int i = 0; i < 3; ++i) depth.at<uint16_t>(rng() % height, rng() % width) = 65535;
  return depth;
}

/// Uniform random depth in [0, max_value] with about 10 % holes.
inline cv::Mat randomDepth(int width, int height, uint32_t seed, int max_value = 65535) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> value(0, max_value);
  cv::Mat depth(height, width, CV_16UC1);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      depth.at<uint16_t>(y, x) = rng() % 10 == 0 ? 0 : static_cast<uint16_t>(value(rng));
  return depth;
}

/// Smooth gradients, shapes and mild noise: what JPEG is meant for.
inline cv::Mat syntheticColor(int width, int height, uint32_t seed) {
  std::mt19937 rng(seed);
  cv::Mat bgr(height, width, CV_8UC3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      bgr.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uint8_t>(255 * x / width), static_cast<uint8_t>(255 * y / height),
                    static_cast<uint8_t>(128 + 100 * std::sin(0.05 * (x + y))));
  cv::circle(bgr, cv::Point(width / 2, height / 2), std::max(1, height / 4), cv::Scalar(30, 200, 90),
             cv::FILLED);
  cv::Mat noise(height, width, CV_8UC3);
  cv::randu(noise, 0, 3);
  bgr += noise;
  return bgr;
}

inline cv::Mat randomColor(int width, int height, uint32_t seed) {
  cv::Mat bgr(height, width, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(bgr, cv::RNG::UNIFORM, 0, 256);
  return bgr;
}

/// Valid blobs of synthetic images, the starting point of the forgery and corruption tests.
inline Bytes depthBlob(DepthFilter filter, int width, int height) {
  ImageCodecOptions options;
  options.depth_filter = filter;
  return encodeDepth(syntheticDepth(width, height, 21), options).value();
}

inline Bytes colorBlob(ColorCodec codec, int width, int height) {
  ImageCodecOptions options;
  options.color = codec;
  return encodeColor(syntheticColor(width, height, 22), options).value();
}

inline bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && (a.empty() || cv::norm(a, b, cv::NORM_INF) == 0);
}

}  // namespace rgbdmap::testing
