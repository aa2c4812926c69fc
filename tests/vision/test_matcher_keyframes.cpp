#include <random>

#include <gtest/gtest.h>

#include "rgbdmap/client/keyframe_selector.hpp"
#include "rgbdmap/vision/matcher.hpp"

namespace rgbdmap {
namespace {

cv::Mat randomDescriptors(int n, std::mt19937& rng) {
  cv::Mat d(n, 32, CV_8U);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < 32; ++c) d.at<uint8_t>(r, c) = static_cast<uint8_t>(byte(rng));
  return d;
}

// Flip `bits` random bits of a descriptor row.
void flipBits(cv::Mat& d, int row, int bits, std::mt19937& rng) {
  std::uniform_int_distribution<int> bit(0, 255);
  for (int i = 0; i < bits; ++i) {
    const int b = bit(rng);
    d.at<uint8_t>(row, b / 8) ^= static_cast<uint8_t>(1u << (b % 8));
  }
}

TEST(Matcher, FindsPermutedNoisyCopies) {
  std::mt19937 rng(1);
  const cv::Mat train = randomDescriptors(300, rng);
  std::vector<int> perm(300);
  for (int i = 0; i < 300; ++i) perm[i] = (i * 7) % 300;
  cv::Mat query(300, 32, CV_8U);
  for (int i = 0; i < 300; ++i) {
    train.row(perm[i]).copyTo(query.row(i));
    flipBits(query, i, 10, rng);
  }
  const auto matches = matchDescriptors(query, train, MatcherConfig{});
  EXPECT_GT(matches.size(), 290u);
  for (const auto& m : matches) EXPECT_EQ(m.train, perm[m.query]);
}

TEST(Matcher, DistanceFilterDropsFarMatches) {
  std::mt19937 rng(2);
  const cv::Mat train = randomDescriptors(200, rng);
  cv::Mat query = train.clone();
  for (int i = 100; i < 200; ++i) flipBits(query, i, 120, rng);  // unrelated descriptors
  MatcherConfig cfg;
  cfg.ratio = 1.0;  // isolate the k x min-distance filter
  const auto matches = matchDescriptors(query, train, cfg);
  for (const auto& m : matches) EXPECT_LT(m.query, 100) << "distance " << m.distance;
  EXPECT_EQ(matches.size(), 100u);
}

TEST(Matcher, OneToOneAndMask) {
  std::mt19937 rng(3);
  const cv::Mat train = randomDescriptors(50, rng);
  cv::Mat query(3, 32, CV_8U);
  for (int i = 0; i < 3; ++i) train.row(5).copyTo(query.row(i));
  flipBits(query, 1, 3, rng);
  flipBits(query, 2, 6, rng);
  auto matches = matchDescriptors(query, train, MatcherConfig{});
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0].query, 0);
  std::vector<char> mask(50, 1);
  mask[5] = 0;
  matches = matchDescriptors(query, train, MatcherConfig{}, &mask);
  for (const auto& m : matches) EXPECT_NE(m.train, 5);
}

TEST(Matcher, EmptyInputs) { EXPECT_TRUE(matchDescriptors(cv::Mat(), cv::Mat(), MatcherConfig{}).empty()); }

TEST(KeyframeSelector, PaperSimilarityRule) {
  EXPECT_DOUBLE_EQ(similarity(300, 1000, 1000), 0.3);
  EXPECT_DOUBLE_EQ(similarity(0, 0, 0), 0.0);
  KeyframeConfig cfg;
  cfg.similarity_threshold = 0.3;
  cfg.max_frame_gap = 30;
  const SE3 I = SE3::Identity();
  EXPECT_FALSE(decideKeyframe(400, 1000, 1000, 5, I, cfg).new_keyframe);
  const auto low = decideKeyframe(200, 1000, 1000, 5, I, cfg);
  EXPECT_TRUE(low.new_keyframe);
  EXPECT_EQ(low.reason, "similarity");
  EXPECT_EQ(decideKeyframe(400, 1000, 1000, 30, I, cfg).reason, "frame_gap");
  SE3 moved = I;
  moved.translation() << 0.3, 0, 0;
  EXPECT_EQ(decideKeyframe(400, 1000, 1000, 5, moved, cfg).reason, "motion");
  SE3 turned = I;
  turned.linear() = Eigen::AngleAxisd(20.0 * M_PI / 180, Vec3::UnitY()).toRotationMatrix();
  EXPECT_EQ(decideKeyframe(400, 1000, 1000, 5, turned, cfg).reason, "motion");
}

}  // namespace
}  // namespace rgbdmap
