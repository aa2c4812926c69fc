#pragma once
// The synthetic scene helpers of the LandmarkMap tests: keyframes of the scene, perturbed starts, the
// scene added with its true matches, and the RMS position error against the ground truth.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "rgbdmap/ba/ba_synth.hpp"

namespace rgbdmap::testing {

using BaScene = BaSynthScene;
using BaSceneOptions = BaSynthConfig;

inline BaScene makeBaScene(const BaSceneOptions& o) { return makeBaSynthScene(o); }
inline EdgeMatches trueMatches(const BaScene& s, int a, int b) { return synthTrueMatches(s, a, b); }
inline LandmarkKeyframe sceneKeyframe(const BaScene& s, int k, const SE3& T, int map_id = 0) {
  return synthKeyframe(s, k, T, map_id);
}

/// RMS position error of keyframes (the first keyframe is the fixed anchor: errors are in a common frame).
inline double positionRms(const std::vector<SE3>& truth, const std::vector<SE3>& est) {
  double sum = 0.0;
  for (size_t i = 0; i < truth.size(); ++i)
    sum += (truth[i].translation() - est[i].translation()).squaredNorm();
  return std::sqrt(sum / static_cast<double>(truth.size()));
}

/// Perturbs every keyframe but the first: sigma_t metres and sigma_r radians per axis.
inline std::vector<SE3> perturbed(const BaScene& s, double sigma_t, double sigma_r, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<SE3> out = s.T_map_kf;
  for (size_t k = 1; k < out.size(); ++k) {
    const Vec6 xi = (Vec6() << sigma_t * n(rng), sigma_t * n(rng), sigma_t * n(rng), sigma_r * n(rng),
                     sigma_r * n(rng), sigma_r * n(rng))
                        .finished();
    out[k] = se3::exp(xi) * out[k];
  }
  return out;
}

/// Adds the scene's keyframes at `start` and the true matches of each to the three before it; with `split`
/// > 0, keyframes before and from `split` on are two parts sharing no match (a part per room). `w_prior`
/// (when given) centres each keyframe's rolling-shutter prior.
inline void addScene(LandmarkMap* map, const BaScene& s, const std::vector<SE3>& start, int split = 0,
                     const std::function<Vec3(int)>& w_prior = nullptr) {
  const int n = static_cast<int>(start.size());
  for (int k = 0; k < n; ++k) {
    LandmarkKeyframe kf = sceneKeyframe(s, k, start[k]);
    if (w_prior) kf.w_prior = w_prior(k);
    EXPECT_TRUE(map->addKeyframe(std::move(kf)));
  }
  for (int k = 0; k < n; ++k)
    for (int j = std::max(split > 0 && k >= split ? split : 0, k - 3); j < k; ++j)
      map->addMatches(trueMatches(s, k, j));
}

inline std::vector<SE3> posesOf(const LandmarkMap& map, size_t n) {
  std::vector<SE3> out;
  for (size_t k = 0; k < n; ++k) out.push_back(*map.pose(static_cast<int64_t>(k)));
  return out;
}

}  // namespace rgbdmap::testing
