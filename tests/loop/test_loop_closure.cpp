// Loop closure units: the motion measure E, candidate selection, binary-word retrieval, and verification
// rejecting false candidates with a reason. End-to-end runs are in test_loop_closure_e2e.cpp.
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "rgbdmap/loop/loop_consistency.hpp"
#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/vision/guided_matcher.hpp"

namespace rgbdmap {
namespace {

SE3 pose(const Vec3& t, const Vec3& rpy) {
  SE3 T = SE3::Identity();
  T.linear() = (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
                Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

TEST(MotionMeasure, MatchesHandComputedValues) {
  // |t| = 0.5 m, yaw 0.2 rad: E = 0.35 * 0.5 + 1.0 * 0.2 = 0.375.
  EXPECT_NEAR(motionMeasure(pose({0.3, 0.4, 0.0}, {0, 0, 0.2}), 0.35, 1.0), 0.375, 1e-12);
  // |t| = 1 m, roll 0.1, pitch 0.2: E = 0.35 + sqrt(0.01 + 0.04) = 0.573607.
  EXPECT_NEAR(motionMeasure(pose({0, 0, 1}, {0.1, 0.2, 0}), 0.35, 1.0), 0.35 + std::sqrt(0.05), 1e-12);
  // Pure rotation of 30 deg about x with k2 = 1: E = pi / 6.
  EXPECT_NEAR(motionMeasure(pose({0, 0, 0}, {M_PI / 6, 0, 0}), 0.35, 1.0), M_PI / 6, 1e-12);
  EXPECT_DOUBLE_EQ(motionMeasure(SE3::Identity(), 0.35, 1.0), 0.0);
}

std::vector<KeyframeSummary> line(int robot, int first_id, int n, int map_id = 0) {
  std::vector<KeyframeSummary> out;
  for (int i = 0; i < n; ++i) out.push_back({first_id + i, robot, map_id, pose({0.5 * i, 0, 0}, {0, 0, 0})});
  return out;
}

bool has(const std::vector<LoopCandidate>& c, int id, uint8_t source) {
  for (const LoopCandidate& x : c)
    if (x.keyframe_id == id) return (x.sources & source) != 0;
  return false;
}

TEST(LoopCandidates, UnionOfRecentRandomNearbyAndRetrievalWithoutDuplicates) {
  std::vector<KeyframeSummary> stored = line(0, 0, 30);  // robot 0: ids 0..29 along x, 0.5 m apart
  const auto other = line(1, 100, 5, 1);                 // robot 1 in its own map frame
  stored.insert(stored.end(), other.begin(), other.end());
  KeyframeSummary query{30, 0, 0, pose({2.2, 0, 0}, {0, 0, 0})};  // back near ids 4 and 5
  const std::vector<RetrievalHit> hits = {{102, 1, 0.4}, {29, 0, 0.3}, {30, 0, 0.9}};
  LoopCandidateConfig config;
  config.max_candidates = 100;
  std::mt19937 rng(3);
  const auto c = selectLoopCandidates(query, stored, hits, config, &rng);
  for (int id = 25; id < 30; ++id) EXPECT_TRUE(has(c, id, kSourceRecent)) << id;
  EXPECT_TRUE(has(c, 102, kSourceRetrieval));
  EXPECT_TRUE(has(c, 29, kSourceRetrieval)) << "dedup merges sources";
  EXPECT_TRUE(has(c, 4, kSourceNearby) && has(c, 5, kSourceNearby));
  int random = 0;
  for (const LoopCandidate& x : c) {
    EXPECT_NE(x.keyframe_id, 30) << "the keyframe itself";
    EXPECT_EQ(std::count_if(c.begin(), c.end(), [&](auto& y) { return y.keyframe_id == x.keyframe_id; }), 1);
    if (x.sources & kSourceRandom) {
      ++random;
      EXPECT_LT(x.keyframe_id, 25) << "random loops come from the older keyframes";
    }
    if (x.keyframe_id >= 100) {
      EXPECT_EQ(x.sources, kSourceRetrieval) << "other robots only via retrieval";
    }
  }
  EXPECT_EQ(random, config.random_l);
}

TEST(LoopCandidates, NearbyRespectsMapFrameAngleAndCap) {
  const KeyframeSummary a{1, 0, 0, pose({0, 0, 0}, {0, 0, 0})};
  EXPECT_TRUE(isNearby(a, {2, 0, 0, pose({0.5, 0, 0}, {0, 0.5, 0})}, 1.0, 45));
  EXPECT_FALSE(isNearby(a, {2, 0, 1, pose({0.5, 0, 0}, {0, 0, 0})}, 1.0, 45)) << "other map frame";
  EXPECT_FALSE(isNearby(a, {2, 0, 0, pose({0.5, 0, 0}, {0, 1.0, 0})}, 1.0, 45)) << "57 deg apart";
  EXPECT_FALSE(isNearby(a, {2, 0, 0, pose({1.2, 0, 0}, {0, 0, 0})}, 1.0, 45)) << "1.2 m apart";

  LoopCandidateConfig config;
  config.max_candidates = 7;
  std::mt19937 rng(1);
  const auto stored = line(0, 0, 40);
  const auto c =
      selectLoopCandidates({40, 0, 0, pose({0, 0, 0}, {0, 0, 0})}, stored, {{3, 0, 0.5}}, config, &rng);
  ASSERT_EQ(c.size(), 7u) << "capped";
  EXPECT_TRUE(has(c, 39, kSourceRecent) && has(c, 3, kSourceRetrieval) && has(c, 0, kSourceNearby));
}

TEST(LoopCandidates, RandomLoopsAreSeeded) {
  const auto stored = line(0, 0, 50);
  LoopCandidateConfig config;
  std::mt19937 a(9), b(9);
  const KeyframeSummary q{50, 0, 0, pose({100, 0, 0}, {0, 0, 0})};
  const auto ca = selectLoopCandidates(q, stored, {}, config, &a);
  const auto cb = selectLoopCandidates(q, stored, {}, config, &b);
  ASSERT_EQ(ca.size(), cb.size());
  for (size_t i = 0; i < ca.size(); ++i) EXPECT_EQ(ca[i].keyframe_id, cb[i].keyframe_id);
}

cv::Mat randomDescriptors(int n, std::mt19937* rng) {
  cv::Mat d(n, 32, CV_8U);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < 32; ++c) d.at<uint8_t>(r, c) = static_cast<uint8_t>(byte(*rng));
  return d;
}

cv::Mat flipBits(cv::Mat d, int bits_per_row, std::mt19937* rng) {
  std::uniform_int_distribution<int> bit(0, 255);
  for (int r = 0; r < d.rows; ++r)
    for (int k = 0; k < bits_per_row; ++k) {
      const int b = bit(*rng);
      d.at<uint8_t>(r, b / 8) ^= static_cast<uint8_t>(1u << (b % 8));
    }
  return d;
}

TEST(BinaryWords, RetrievalRanksARevisitAboveUnrelatedKeyframesAndExcludesRecentOnes) {
  std::mt19937 rng(5);
  const BinaryWordHasher hasher;
  BinaryWordIndex index;
  std::vector<cv::Mat> places;
  for (int i = 0; i < 200; ++i) {
    places.push_back(randomDescriptors(500, &rng));
    index.insert(i, i % 2, i / 2, hasher.histogram(places.back()));
  }
  // A revisit of place 42 (robot 0): same descriptors with 25 of 256 bits flipped each.
  const WordHistogram revisit = hasher.histogram(flipBits(places[42].clone(), 25, &rng));
  RetrievalQuery q;
  q.robot_id = 1;  // another robot: nothing excluded
  const auto hits = index.query(revisit, q);
  ASSERT_FALSE(hits.empty());
  EXPECT_EQ(hits[0].keyframe_id, 42);
  EXPECT_GT(hits[0].score, 5 * (hits.size() > 1 ? hits[1].score : 0.0)) << hits[0].score;
  q.robot_id = 0;
  q.robot_sequence = 30;  // place 42 is robot 0's 21st keyframe: within the 15 most recent
  for (const RetrievalHit& h : index.query(revisit, q)) EXPECT_NE(h.keyframe_id, 42);
  EXPECT_NEAR(index.query(hasher.histogram(places[7]), {2, 0, 15, 1, 0.0})[0].score, 1.0, 1e-4);
}

// Posting lists are varint-coded gaps with counts. Scores equal a plain inverted index's (every
// document's idf-weighted histogram intersection, by brute force), over gaps of one and of several varint
// bytes (a word seen again after 200 or 20,000 documents) and counts of 1, 2 and 300.
TEST(BinaryWords, CompressedPostingsScoreAsAPlainIndex) {
  std::mt19937 rng(9);
  const BinaryWordsConfig config;
  BinaryWordIndex index(config);
  std::vector<WordHistogram> docs;
  std::uniform_int_distribution<uint32_t> word(0, 5000);
  const int n = 20210;
  for (int i = 0; i < n; ++i) {
    std::set<uint32_t> words;
    const bool rare = i == 3 || i == 203 || i == 20203 - 3;  // gaps of 200 and 19,997 for word 60,000
    if (rare) words.insert(60000);
    for (int k = 0; k < 20; ++k) words.insert(word(rng));
    WordHistogram h;
    for (uint32_t w : words) h.emplace_back(w, static_cast<uint16_t>(w % 7 == 0 ? 2 : w % 11 == 0 ? 300 : 1));
    index.insert(i, 0, i, h);
    docs.push_back(h);
  }
  EXPECT_EQ(index.postings(), [&] {
    uint64_t p = 0;
    for (const WordHistogram& h : docs) p += h.size();
    return p;
  }());
  EXPECT_LT(index.memoryBytes(), index.postings() * 3 + 8'000'000) << "postings are not compact";
  std::map<uint32_t, int> df;
  for (const WordHistogram& h : docs)
    for (const auto& [w, c] : h) ++df[w];
  for (int probe : {3, 203, 7777, n - 1}) {
    WordHistogram query = docs[probe];
    RetrievalQuery q;
    q.robot_id = 1;
    q.top_n = 5;
    const auto hits = index.query(query, q);
    ASSERT_FALSE(hits.empty());
    // The reference: the same score for every document, best first.
    std::vector<std::pair<double, int>> ref;
    double mass = 0.0;
    std::map<uint32_t, double> weight;
    for (const auto& [w, c] : query) {
      const double idf = std::log((n + 1.0) / (df[w] + 1.0));
      mass += idf * c;
      if (df[w] <= config.stop_word_fraction * n) weight[w] = idf;
    }
    for (int d = 0; d < n; ++d) {
      double score = 0.0;
      for (const auto& [w, c] : docs[d]) {
        const auto it = weight.find(w);
        if (it == weight.end()) continue;
        const auto qc = std::lower_bound(query.begin(), query.end(), std::make_pair(w, uint16_t{0}));
        score += it->second * std::min(c, qc->second);
      }
      if (score > 0.0) ref.emplace_back(score / mass, d);
    }
    std::sort(ref.begin(), ref.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    EXPECT_EQ(hits[0].keyframe_id, probe);
    for (size_t i = 0; i < hits.size(); ++i) EXPECT_NEAR(hits[i].score, ref[i].first, 1e-4) << i;
  }
}

/// n features with random descriptors at random pixels and depths (0.5-3.5 m) of a 640x480 camera.
FrameFeatures randomFeatures(int n, const PinholeCamera& camera, std::mt19937* rng) {
  FrameFeatures f;
  f.descriptors = randomDescriptors(n, rng);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    f.keypoints.emplace_back(static_cast<float>(640 * u(*rng)), static_cast<float>(480 * u(*rng)), 31.f);
    f.px.emplace_back(f.keypoints.back().pt.x, f.keypoints.back().pt.y);
    f.depth_m.push_back(0.5 + 3 * u(*rng));
    f.p_cam.push_back(camera.backProject(f.px.back(), f.depth_m.back()));
  }
  return f;
}

TEST(LoopVerify, RandomDescriptorNoiseIsRejectedWithAReason) {
  std::mt19937 rng(11);
  CameraIntrinsics k;
  k.distortion = {0, 0, 0, 0, 0};
  const FrameFeatures a = randomFeatures(800, PinholeCamera(k), &rng);
  const FrameFeatures b = randomFeatures(800, PinholeCamera(k), &rng);
  const LoopVerification v = verifyLoop(1, a, 2, b, PinholeCamera(k), LoopVerifyConfig{},
                                        localThresholds(LoopVerifyConfig{}, std::nullopt));
  EXPECT_FALSE(v.edge.has_value());
  EXPECT_TRUE(v.rejection == LoopRejection::kTooFewMatches || v.rejection == LoopRejection::kRansacFailed)
      << toString(v.rejection) << " matches " << v.matches;
}

// Which candidates are matched all against all (the costly path) is reported: without a prior,
// and when matching by projection under the prior finds too few matches; not when it finds enough.
TEST(LoopVerify, ReportsWhenItMatchesAllAgainstAll) {
  std::mt19937 rng(12);
  CameraIntrinsics k;
  k.distortion = {0, 0, 0, 0, 0};
  const PinholeCamera camera(k);
  const FrameFeatures a = randomFeatures(400, camera, &rng);
  const FrameFeatures noise = randomFeatures(400, camera, &rng);
  const LoopVerifyConfig config;
  const FeatureGrid grid(a, k.width, k.height);
  const SE3 identity = SE3::Identity();
  // The same view under the identity prior: matching by projection finds every feature.
  const LoopVerification same =
      verifyLoop(1, a, 2, a, camera, config, localThresholds(config, identity), &grid);
  EXPECT_TRUE(same.had_prior);
  EXPECT_FALSE(same.brute_force) << same.matches << " matches";
  EXPECT_TRUE(same.edge.has_value()) << toString(same.rejection);
  // No prior: all against all.
  const LoopVerification blind =
      verifyLoop(1, a, 2, a, camera, config, localThresholds(config, std::nullopt), &grid);
  EXPECT_FALSE(blind.had_prior);
  EXPECT_TRUE(blind.brute_force);
  // Unrelated features under a prior: too few matches by projection, then all against all.
  const LoopVerification fallback =
      verifyLoop(1, a, 2, noise, camera, config, localThresholds(config, identity), &grid);
  EXPECT_TRUE(fallback.had_prior);
  EXPECT_TRUE(fallback.brute_force);
  EXPECT_FALSE(fallback.fallback_refused);
  EXPECT_FALSE(fallback.edge.has_value());
  // The same without the fallback (a keyframe's loop.max_fallbacks_per_keyframe spent): rejected for too
  // few matches, not matched all against all; a candidate without a prior is still matched all against all,
  // and one that matches by projection is not affected.
  LoopThresholds spent = localThresholds(config, identity);
  spent.allow_fallback = false;
  const LoopVerification refused = verifyLoop(1, a, 2, noise, camera, config, spent, &grid);
  EXPECT_TRUE(refused.fallback_refused);
  EXPECT_FALSE(refused.brute_force);
  EXPECT_EQ(refused.rejection, LoopRejection::kTooFewMatches);
  LoopThresholds blind_spent = localThresholds(config, std::nullopt);
  blind_spent.allow_fallback = false;
  EXPECT_TRUE(verifyLoop(1, a, 2, a, camera, config, blind_spent, &grid).brute_force);
  const LoopVerification same_spent = verifyLoop(1, a, 2, a, camera, config, spent, &grid);
  EXPECT_FALSE(same_spent.fallback_refused);
  EXPECT_TRUE(same_spent.edge.has_value());
}

TEST(LoopDetectorConfig, DefaultsAreValidAndBadValuesAreAllReported) {
  EXPECT_EQ(LoopDetectorConfig{}.validate(), "");
  LoopDetectorConfig bad;
  bad.candidates.max_candidates = 0;
  bad.verify.k1 = -1;
  bad.words.bits_per_word = 32;
  const std::string reasons = bad.validate();
  EXPECT_NE(reasons.find("max_candidates"), std::string::npos) << reasons;
  EXPECT_NE(reasons.find("k1"), std::string::npos) << reasons;
  EXPECT_NE(reasons.find("bits_per_word"), std::string::npos) << reasons;
}

TEST(LoopConsistency, DropsAnEdgeContradictedByMostOfItsTriangles) {
  // Keyframes A=1, B=2, C=3 verified earlier; the new keyframe X=9 has edges to all three.
  const SE3 T_w_x = pose({0, 0, 0}, {0, 0, 0}), T_w_a = pose({0.3, 0, 0}, {0, 0.1, 0}),
            T_w_b = pose({0.5, 0.1, 0}, {0, 0.2, 0}), T_w_c = pose({0.7, 0, 0.1}, {0.1, 0.2, 0});
  LoopEdgeStore store;
  store.add({2, 1, T_w_b.inverse() * T_w_a, Mat6::Identity(), 100, 0.1, {}});
  store.add({3, 1, T_w_c.inverse() * T_w_a, Mat6::Identity(), 100, 0.1, {}});
  store.add({3, 2, T_w_c.inverse() * T_w_b, Mat6::Identity(), 100, 0.1, {}});
  auto edge = [&](int to, const SE3& T_w_to) {
    return LoopEdge{9, to, T_w_x.inverse() * T_w_to, Mat6::Identity(), 80, 0.2, {}};
  };
  std::vector<LoopEdge> edges = {edge(1, T_w_a), edge(2, T_w_b), edge(3, T_w_c)};
  EXPECT_EQ(checkEdgeConsistency(edges, store, {}), (std::vector<char>{1, 1, 1}));
  edges[0].T_from_to.translation() += Vec3(0.15, 0, 0);  // X->A biased by 15 cm
  EXPECT_EQ(checkEdgeConsistency(edges, store, {}), (std::vector<char>{0, 1, 1}));
  edges.pop_back();  // with one triangle left there is nothing to outvote: kept
  EXPECT_EQ(checkEdgeConsistency(edges, store, {}), (std::vector<char>{1, 1}));
}

}  // namespace
}  // namespace rgbdmap
