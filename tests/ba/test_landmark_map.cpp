// Landmark tracks and bundle adjustment on a synthetic scene with exact ground truth: tracks from verified
// matches, conflicts and fusion, links taken back, matching by projection (its links must be right), and
// local and global BA recovering perturbed poses, with wrong matches injected and removed.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <set>

#include "ba/landmark_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::addScene;
using testing::BaScene;
using testing::BaSceneOptions;
using testing::makeBaScene;
using testing::perturbed;
using testing::posesOf;
using testing::positionRms;
using testing::sceneKeyframe;
using testing::trueMatches;

/// Fraction of observations whose features belong to the landmark's majority scene point.
double trackPurity(const LandmarkMap& map, const BaScene& s, int64_t max_landmark) {
  int64_t good = 0, all = 0;
  for (int64_t l = 0; l < max_landmark; ++l) {
    const auto obs = map.observationsOf(l);
    if (obs.empty()) continue;
    std::map<int, int> votes;
    for (const auto& [kf, f] : obs) ++votes[s.point_of_feature[kf][f]];
    int best = 0;
    for (const auto& [p, n] : votes) best = std::max(best, n);
    good += best;
    all += static_cast<int64_t>(obs.size());
  }
  return all ? static_cast<double>(good) / static_cast<double>(all) : 0.0;
}

TEST(LandmarkMap, TracksFromMatchesFollowScenePoints) {
  const BaScene s = makeBaScene({});
  LandmarkMap map;
  for (size_t k = 0; k < s.features.size(); ++k)
    ASSERT_TRUE(map.addKeyframe(sceneKeyframe(s, static_cast<int>(k), s.T_map_kf[k])));
  EXPECT_FALSE(map.addKeyframe(sceneKeyframe(s, 0, s.T_map_kf[0])));  // duplicate
  for (int k = 1; k < static_cast<int>(s.features.size()); ++k)
    EXPECT_GT(map.addMatches(trueMatches(s, k - 1, k)), 0);
  const LandmarkStats st = map.stats();
  EXPECT_GT(st.landmarks, 500);
  EXPECT_DOUBLE_EQ(trackPurity(map, s, 100000), 1.0);
  // A point seen by every keyframe is one landmark with one observation per keyframe.
  EXPECT_GT(st.observations, 2 * st.landmarks);
  for (int64_t l = 0; l < 100000; ++l) {
    const auto obs = map.observationsOf(l);
    std::set<int64_t> kfs;
    for (const auto& o : obs) EXPECT_TRUE(kfs.insert(o.first).second) << "two features of one keyframe";
  }
}

TEST(LandmarkMap, FusionConflictsAndRemoval) {
  const BaScene s = makeBaScene({});
  LandmarkMap map;
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(map.addKeyframe(sceneKeyframe(s, k, s.T_map_kf[k])));
  map.addMatches(trueMatches(s, 0, 1));
  map.addMatches(trueMatches(s, 2, 3));
  const int64_t before = map.stats().landmarks;
  // 1-2 joins the two sets of tracks: landmarks fuse, none is created.
  EXPECT_GT(map.addMatches(trueMatches(s, 1, 2)), 0);
  EXPECT_LT(map.stats().landmarks, before);
  EXPECT_GT(map.stats().fusions, 0);
  EXPECT_DOUBLE_EQ(trackPurity(map, s, 100000), 1.0);
  // A wrong pair that would put a second feature of keyframe 0 into a track it is in: refused.
  const EdgeMatches m01 = trueMatches(s, 0, 1);
  ASSERT_GE(m01.pairs.size(), 2u);
  EdgeMatches wrong{0, 1, {{m01.pairs[0].first, m01.pairs[1].second}}};
  const int64_t l0 = map.landmarkOf(0, m01.pairs[0].first);
  map.addMatches(wrong);
  EXPECT_EQ(map.landmarkOf(0, m01.pairs[0].first), l0);
  EXPECT_DOUBLE_EQ(trackPurity(map, s, 100000), 1.0);
  // Taking 2-3 back, from the matches as the server keeps them (packed): keyframe 3 leaves the tracks it
  // shared with 2.
  const EdgeMatches m23 = trueMatches(s, 2, 3);
  const int64_t observations = map.stats().observations;
  EXPECT_GT(map.removeMatches(PackedMatches::pack(m23).unpack()), 0);
  EXPECT_LT(map.stats().observations, observations);
  for (const auto& [a, b] : m23.pairs) {
    const int64_t la = map.landmarkOf(2, a);
    EXPECT_TRUE(la < 0 || la != map.landmarkOf(3, b));
  }
}

// Matches kept for long take 4 bytes a pair when every index fits 16 bits, and come back as they
// went in, in order; others are kept as they came.
TEST(LandmarkMap, PackedMatchesComeBackAsTheyWentIn) {
  EdgeMatches m{7, 3, {{0, 0}, {65535, 1}, {12, 65535}, {999, 998}}};
  const PackedMatches p = PackedMatches::pack(m);
  EXPECT_EQ(p.packed.size(), 4u);
  EXPECT_TRUE(p.wide.empty());
  const EdgeMatches back = p.unpack();
  EXPECT_EQ(back.from, 7);
  EXPECT_EQ(back.to, 3);
  EXPECT_EQ(back.pairs, m.pairs);
  for (const auto& odd : {std::pair<int, int>{65536, 0}, {0, -1}}) {
    EdgeMatches w = m;
    w.pairs.push_back(odd);
    const PackedMatches q = PackedMatches::pack(w);
    EXPECT_TRUE(q.packed.empty());
    EXPECT_EQ(q.unpack().pairs, w.pairs);
  }
}

// The tracks' memory is reported and keyframe ids beyond 32 bits are refused (observations
// hold them in 32 bits).
TEST(LandmarkMap, ReportsItsMemoryAndRefusesKeyframeIdsBeyond32Bits) {
  const BaScene s = makeBaScene({});
  LandmarkMap map;
  ASSERT_TRUE(map.addKeyframe(sceneKeyframe(s, 0, s.T_map_kf[0])));
  ASSERT_TRUE(map.addKeyframe(sceneKeyframe(s, 1, s.T_map_kf[1])));
  const int64_t empty = map.stats().memory_bytes;
  EXPECT_GT(empty, 0);
  ASSERT_GT(map.addMatches(trueMatches(s, 0, 1)), 0);
  const LandmarkStats st = map.stats();
  EXPECT_GE(st.memory_bytes - empty, st.landmarks * 56 + st.observations * 8);
  LandmarkKeyframe big = sceneKeyframe(s, 2, s.T_map_kf[2]);
  big.id = int64_t{1} << 32;
  EXPECT_FALSE(map.addKeyframe(big));
}

TEST(LandmarkMap, KeyframesOfDifferentMapsShareNoLandmark) {
  const BaScene s = makeBaScene({});
  LandmarkMap map;
  ASSERT_TRUE(map.addKeyframe(sceneKeyframe(s, 0, s.T_map_kf[0], 0)));
  ASSERT_TRUE(map.addKeyframe(sceneKeyframe(s, 1, s.T_map_kf[1], 1)));
  EXPECT_EQ(map.addMatches(trueMatches(s, 0, 1)), 0);
  map.setPose(1, 0, s.T_map_kf[1]);  // merged
  EXPECT_GT(map.addMatches(trueMatches(s, 0, 1)), 0);
}

TEST(LandmarkMap, ProjectionExtendsTracksCorrectly) {
  BaSceneOptions o;
  o.keyframes = 8;
  const BaScene s = makeBaScene(o);
  LandmarkMap map;
  for (int k = 0; k < o.keyframes; ++k) ASSERT_TRUE(map.addKeyframe(sceneKeyframe(s, k, s.T_map_kf[k])));
  // Consecutive pairs up to keyframe 5 are matched; keyframe 7 gets 40 pairs with 5 only.
  for (int k = 1; k < 6; ++k) map.addMatches(trueMatches(s, k - 1, k));
  const int64_t links_before = map.stats().observations;
  // With those it is covisible with 5; projection must find what it sees of the landmarks of 5 (and 4, 3...).
  EdgeMatches seed = trueMatches(s, 7, 5);
  seed.pairs.resize(std::min<size_t>(seed.pairs.size(), 40));
  map.addMatches(seed);
  const int added = map.extendByProjection(7);
  EXPECT_GT(added, 200) << "projection found few of the landmarks keyframe 7 sees";
  EXPECT_GT(map.stats().observations, links_before + 200);
  EXPECT_GT(trackPurity(map, s, 100000), 0.995);
}

TEST(LandmarkMap, LocalAndGlobalAdjustmentRecoverPoses) {
  BaSceneOptions o;
  o.keyframes = 12;
  const BaScene s = makeBaScene(o);
  const std::vector<SE3> start = perturbed(s, 0.02, 0.01, 11);
  LandmarkMap map;
  addScene(&map, s, start);
  const double rms0 = positionRms(s.T_map_kf, posesOf(map, s.T_map_kf.size()));
  const BundleResult local = map.localAdjust(o.keyframes - 1, 0);
  ASSERT_TRUE(local.ok) << local.error;
  EXPECT_GE(local.moved.size(), 3u);
  const BundleResult global = map.globalAdjust(0, 0);
  ASSERT_TRUE(global.ok) << global.error;
  const double rms1 = positionRms(s.T_map_kf, posesOf(map, s.T_map_kf.size()));
  std::printf("[ measured ] keyframe position rms %.4f m -> %.5f m; global BA %.1f ms, %d obs, rms %.2f px\n",
              rms0, rms1, global.report.time_ms, global.report.observations, global.report.final_rms_px);
  EXPECT_GT(rms0, 0.015);
  EXPECT_LT(rms1, 0.003);
  EXPECT_TRUE(map.pose(0)->isApprox(start[0], 1e-12)) << "the anchor moved";
}

TEST(LandmarkMap, WrongMatchesAreRemovedAndDoNotSpoilTheResult) {
  BaSceneOptions o;
  o.keyframes = 12;
  const BaScene s = makeBaScene(o);
  const std::vector<SE3> start = perturbed(s, 0.02, 0.01, 12);
  auto run = [&](double wrong_fraction) {
    LandmarkMap map;
    for (int k = 0; k < o.keyframes; ++k) EXPECT_TRUE(map.addKeyframe(sceneKeyframe(s, k, start[k])));
    std::mt19937 rng(5);
    for (int k = 0; k < o.keyframes; ++k)
      for (int j = std::max(0, k - 3); j < k; ++j) {
        EdgeMatches m = trueMatches(s, k, j);
        // Wrong pairs: a feature of k with a random feature of j.
        std::uniform_int_distribution<int> any_j(0, static_cast<int>(s.features[j]->size()) - 1);
        const size_t n_wrong = static_cast<size_t>(wrong_fraction * static_cast<double>(m.pairs.size()));
        for (size_t w = 0; w < n_wrong; ++w) m.pairs[w].second = any_j(rng);
        map.addMatches(m);
      }
    for (int round = 0; round < 2; ++round) EXPECT_TRUE(map.globalAdjust(0, 0).ok);
    return std::make_pair(positionRms(s.T_map_kf, posesOf(map, s.T_map_kf.size())), map.stats());
  };
  const auto [clean, clean_stats] = run(0.0);
  const auto [dirty, dirty_stats] = run(0.15);
  std::printf("[ measured ] 15%% wrong matches: rms %.5f m (clean %.5f m), %lld observations rejected\n",
              dirty, clean, static_cast<long long>(dirty_stats.observations_rejected));
  EXPECT_GT(dirty_stats.observations_rejected, 200);
  EXPECT_LT(dirty, clean + 0.002);
  EXPECT_LT(dirty, 0.004);
}

}  // namespace
}  // namespace rgbdmap
