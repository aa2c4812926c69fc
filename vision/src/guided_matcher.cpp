#include "rgbdmap/vision/guided_matcher.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>

#include "hamming_kernels.hpp"

namespace rgbdmap {

FeatureGrid::FeatureGrid(const FrameFeatures& features, int width, int height, int cell_px)
    : cell_(cell_px),
      cols_((width + cell_px - 1) / cell_px),
      rows_((height + cell_px - 1) / cell_px),
      start_(static_cast<size_t>(cols_) * rows_ + 1, 0),
      descriptors_(vision_detail::packRows(features.descriptors)) {
  std::vector<int> cell_of(features.size(), -1);
  for (size_t i = 0; i < features.size(); ++i) {
    const int cx = static_cast<int>(features.px[i].x()) / cell_,
              cy = static_cast<int>(features.px[i].y()) / cell_;
    if (cx < 0 || cy < 0 || cx >= cols_ || cy >= rows_) continue;
    cell_of[i] = cy * cols_ + cx;
    ++start_[static_cast<size_t>(cell_of[i]) + 1];
  }
  for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
  entries_.resize(start_.back());
  std::vector<size_t> next(start_.begin(), start_.end() - 1);
  for (size_t i = 0; i < features.size(); ++i)
    if (cell_of[i] >= 0)
      entries_[next[static_cast<size_t>(cell_of[i])]++] = {features.px[i].x(), features.px[i].y(),
                                                           static_cast<int>(i)};
}

void FeatureGrid::query(double x, double y, double radius, std::vector<int>* out) const {
  out->clear();
  forEachNear(x, y, radius, [out](int i) { out->push_back(i); });
}

namespace {

/// The two closest descriptors to `descriptor` among the keypoints within `radius` of (x, y); ties keep the
/// first in the grid's order (not necessarily the lowest index).
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("popcnt", "default")))
#endif
vision_detail::NearestTwo nearestTwoAround(const FeatureGrid& grid, const uint64_t* descriptor, double x, double y,
                            double radius) {
  vision_detail::NearestTwo n;
  grid.forEachNear(x, y, radius, [&](int i) __attribute__((always_inline)) {
    n.offer(vision_detail::hamming256(descriptor, grid.descriptor(i)), i);
  });
  return n;
}

}  // namespace

std::vector<FeatureMatch> matchByProjection(const FrameFeatures& cur, const FeatureGrid& grid,
                                            const FrameFeatures& kf, const SE3& T_cur_kf,
                                            const PinholeCamera& camera, const GuidedMatchConfig& config) {
  std::vector<int> best_for_cur(cur.size(), -1);  // index into `candidates`
  std::vector<FeatureMatch> candidates;
  double radius_at_octave[32];
  for (int o = 0; o < 32; ++o) radius_at_octave[o] = config.radius_px * std::pow(1.2, o);
  uint64_t descriptor[4];
  for (size_t k = 0; k < kf.size(); ++k) {
    if (!kf.hasDepth(k)) continue;
    const auto px = camera.project(T_cur_kf * kf.p_cam[k]);
    if (!px || !camera.inImage(*px)) continue;
    const int octave = kf.keypoints[k].octave;
    const double radius = octave >= 0 && octave < 32 ? radius_at_octave[octave]
                                                     : config.radius_px * std::pow(1.2, octave);
    std::memcpy(descriptor, kf.descriptors.ptr<uint8_t>(static_cast<int>(k)), 32);
    const vision_detail::NearestTwo n = nearestTwoAround(grid, descriptor, px->x(), px->y(), radius);
    if (n.index < 0 || n.best > config.max_distance || (n.second != INT_MAX && n.best > config.ratio * n.second))
      continue;
    int& slot = best_for_cur[static_cast<size_t>(n.index)];
    if (slot >= 0 && candidates[static_cast<size_t>(slot)].distance <= n.best) continue;
    if (slot < 0) {
      slot = static_cast<int>(candidates.size());
      candidates.push_back({n.index, static_cast<int>(k), n.best});
    } else {
      candidates[static_cast<size_t>(slot)] = {n.index, static_cast<int>(k), n.best};
    }
  }
  return candidates;
}

}  // namespace rgbdmap
