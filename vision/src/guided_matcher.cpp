#include "rgbdmap/vision/guided_matcher.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>

namespace rgbdmap {
FeatureGrid::FeatureGrid(const FrameFeatures& features, int width, int height, int cell_px)
    : features_(features),
      cell_(cell_px),
      cols_((width + cell_px - 1) / cell_px),
      rows_((height + cell_px - 1) / cell_px),
      cells_(static_cast<size_t>(cols_) * rows_) {
  for (size_t i = 0; i < features.size(); ++i) {
    const int cx = static_cast<int>(features.px[i].x()) / cell_,
              cy = static_cast<int>(features.px[i].y()) / cell_;
    if (cx >= 0 && cy >= 0 && cx < cols_ && cy < rows_)
      cells_[cy * cols_ + cx].push_back(static_cast<int>(i));
  }
}

void FeatureGrid::query(double x, double y, double radius, std::vector<int>* out) const {
  out->clear();
  const int x0 = std::max(0, static_cast<int>((x - radius) / cell_));
  const int x1 = std::min(cols_ - 1, static_cast<int>((x + radius) / cell_));
  const int y0 = std::max(0, static_cast<int>((y - radius) / cell_));
  const int y1 = std::min(rows_ - 1, static_cast<int>((y + radius) / cell_));
  const double r2 = radius * radius;
  for (int cy = y0; cy <= y1; ++cy)
    for (int cx = x0; cx <= x1; ++cx)
      for (int i : cells_[cy * cols_ + cx])
        if ((features_.px[i] - Eigen::Vector2d(x, y)).squaredNorm() <= r2) out->push_back(i);
}

std::vector<FeatureMatch> matchByProjection(const FrameFeatures& cur, const FeatureGrid& grid,
                                            const FrameFeatures& kf, const SE3& T_cur_kf,
                                            const PinholeCamera& camera, const GuidedMatchConfig& config) {
  std::vector<int> best_for_cur(cur.size(), -1);  // index into `candidates`
  std::vector<FeatureMatch> candidates;
  std::vector<int> nearby;
  for (size_t k = 0; k < kf.size(); ++k) {
    if (!kf.hasDepth(k)) continue;
    const auto px = camera.project(T_cur_kf * kf.p_cam[k]);
    if (!px || !camera.inImage(*px)) continue;
    const double radius = config.radius_px * std::pow(1.2, kf.keypoints[k].octave);
    grid.query(px->x(), px->y(), radius, &nearby);
    int best = INT_MAX, second = INT_MAX, best_i = -1;
    for (int i : nearby) {
      const int d =
          hammingDistance(kf.descriptors.ptr<uint8_t>(static_cast<int>(k)), cur.descriptors.ptr<uint8_t>(i));
      if (d < best) {
        second = best;
        best = d;
        best_i = i;
      } else if (d < second) {
        second = d;
      }
    }
    if (best_i < 0 || best > config.max_distance || (second != INT_MAX && best > config.ratio * second))
      continue;
    int& slot = best_for_cur[best_i];
    if (slot >= 0 && candidates[slot].distance <= best) continue;
    if (slot < 0) {
      slot = static_cast<int>(candidates.size());
      candidates.push_back({best_i, static_cast<int>(k), best});
    } else {
      candidates[slot] = {best_i, static_cast<int>(k), best};
    }
  }
  return candidates;
}

}  // namespace rgbdmap
