#include <algorithm>
#include <climits>
#include <random>
#include <string>

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

/// The matcher's rules written out one distance at a time: nearest two over the usable train rows (the
/// lowest index on ties), then the distance, ratio and one-to-one filters.
std::vector<FeatureMatch> referenceMatches(const cv::Mat& query, const cv::Mat& train, const MatcherConfig& config,
                                           const std::vector<char>* mask) {
  struct Nearest {
    int best = INT_MAX, second = INT_MAX, index = -1;
  };
  std::vector<Nearest> nearest(static_cast<size_t>(query.rows));
  int min_distance = INT_MAX;
  for (int q = 0; q < query.rows; ++q) {
    Nearest& n = nearest[static_cast<size_t>(q)];
    for (int t = 0; t < train.rows; ++t) {
      if (mask && !(*mask)[static_cast<size_t>(t)]) continue;
      int d = 0;
      for (int c = 0; c < 32; ++c) d += __builtin_popcount(query.at<uint8_t>(q, c) ^ train.at<uint8_t>(t, c));
      if (d < n.best) {
        n.second = n.best;
        n.best = d;
        n.index = t;
      } else if (d < n.second) {
        n.second = d;
      }
    }
    if (n.index >= 0) min_distance = std::min(min_distance, n.best);
  }
  std::vector<FeatureMatch> out;
  if (min_distance == INT_MAX) return out;
  const double limit = std::min<double>(
      config.max_distance, std::max<double>(config.k_min_distance * min_distance, config.min_distance_floor));
  std::vector<int> owner(static_cast<size_t>(train.rows), -1);
  for (int q = 0; q < query.rows; ++q) {
    const Nearest& n = nearest[static_cast<size_t>(q)];
    if (n.index < 0 || n.best > limit || (n.second != INT_MAX && n.best > config.ratio * n.second)) continue;
    int& o = owner[static_cast<size_t>(n.index)];
    if (o < 0 || nearest[static_cast<size_t>(o)].best > n.best) o = q;
  }
  for (int t = 0; t < train.rows; ++t)
    if (owner[static_cast<size_t>(t)] >= 0)
      out.push_back({owner[static_cast<size_t>(t)], t, nearest[static_cast<size_t>(owner[static_cast<size_t>(t)])].best});
  return out;
}

void expectSameMatches(const std::vector<FeatureMatch>& got, const std::vector<FeatureMatch>& want,
                       const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].query, want[i].query) << what << " match " << i;
    EXPECT_EQ(got[i].train, want[i].train) << what << " match " << i;
    EXPECT_EQ(got[i].distance, want[i].distance) << what << " match " << i;
  }
}

// The vectorised search gives the same matches as the rules one distance at a time: noisy copies, exact
// duplicates in the train set (ties), masked rows, a single usable row, train sets of odd sizes.
TEST(Matcher, EqualsTheRulesOneDistanceAtATime) {
  std::mt19937 rng(11);
  for (const int n_train : {1, 2, 7, 64, 333, 1000}) {
    cv::Mat train = randomDescriptors(n_train, rng);
    for (int r = 1; r < n_train; r += 5) train.row(r - 1).copyTo(train.row(r));  // ties
    cv::Mat query(std::min(n_train, 200), 32, CV_8U);
    for (int i = 0; i < query.rows; ++i) {
      train.row((i * 13) % n_train).copyTo(query.row(i));
      flipBits(query, i, i % 40, rng);
    }
    std::vector<char> mask(static_cast<size_t>(n_train));
    for (int t = 0; t < n_train; ++t) mask[static_cast<size_t>(t)] = (t % 3) != 1;
    std::vector<char> one(static_cast<size_t>(n_train), 0);
    one[static_cast<size_t>(n_train - 1)] = 1;
    MatcherConfig loose;
    loose.ratio = 1.0;
    loose.max_distance = 256;
    for (const MatcherConfig& config : {MatcherConfig{}, loose}) {
      const std::string what = "train " + std::to_string(n_train);
      expectSameMatches(matchDescriptors(query, train, config), referenceMatches(query, train, config, nullptr),
                        what);
      expectSameMatches(matchDescriptors(query, train, config, &mask),
                        referenceMatches(query, train, config, &mask), what + ", masked");
      expectSameMatches(matchDescriptors(query, train, config, &one), referenceMatches(query, train, config, &one),
                        what + ", one usable row");
    }
  }
}

// More train rows than the vectorised search numbers (65,536): the same nearest row.
TEST(Matcher, ManyTrainRows) {
  std::mt19937 rng(12);
  const cv::Mat train = randomDescriptors(70000, rng);
  cv::Mat query(2, 32, CV_8U);
  train.row(68000).copyTo(query.row(0));
  train.row(12).copyTo(query.row(1));
  flipBits(query, 1, 4, rng);
  MatcherConfig loose;
  loose.ratio = 1.0;
  expectSameMatches(matchDescriptors(query, train, loose), referenceMatches(query, train, loose, nullptr), "70,000");
  const auto matches = matchDescriptors(query, train, loose);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[1].train, 68000);
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
