#pragma once
// Brute-force Hamming matching with the outlier filters of Hu et al. 2017 plus a ratio test.
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "rgbdmap/vision/vision_config.hpp"

namespace rgbdmap {

struct FeatureMatch {
  int query;     ///< index into the query (current) frame's features
  int train;     ///< index into the train (reference) frame's features
  int distance;  ///< Hamming distance
};

/// Hamming distance between two 256-bit ORB descriptors (32 bytes each).
int hammingDistance(const uint8_t* a, const uint8_t* b);

/// Matches every query descriptor to its nearest train descriptor (exhaustive Hamming search),
/// keeps a match if (a) it passes the ratio test against the second-nearest, (b) its distance is at most
/// max(k x the minimum distance over all matches, floor) and max_distance, and (c) no better match claims
/// the same train descriptor (one-to-one). `train_mask`, if given, selects usable train rows.
std::vector<FeatureMatch> matchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                           const MatcherConfig& config,
                                           const std::vector<char>* train_mask = nullptr);

}  // namespace rgbdmap
