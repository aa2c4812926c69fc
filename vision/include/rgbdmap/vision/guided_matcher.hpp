#pragma once
// Matching by projection: with a pose estimate, a keyframe's 3-D points are projected into the current
// image and compared only with the current keypoints nearby. Used to add a window of keyframes to a pose
// that brute-force matching against the reference keyframe already found (ORB-SLAM's local-map idea).
#include <algorithm>
#include <cstdint>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/vision/features.hpp"
#include "rgbdmap/vision/guided_match_config.hpp"
#include "rgbdmap/vision/matcher.hpp"

namespace rgbdmap {

/// Buckets the current frame's undistorted keypoints for radius queries, with their descriptors packed
/// beside them for matching.
class FeatureGrid {
 public:
  FeatureGrid(const FrameFeatures& features, int width, int height, int cell_px = 16);
  /// Indices of keypoints within `radius` of (x, y) (cell-level candidates, exact distance checked), in
  /// row-major cell order and ascending index within a cell.
  void query(double x, double y, double radius, std::vector<int>* out) const;
  /// fn(index) for each keypoint within `radius` of (x, y), in the order query() returns them. Always
  /// inlined, so that it takes the instruction set of a caller compiled for a specific CPU.
  template <class Fn>
  [[gnu::always_inline]] inline void forEachNear(double x, double y, double radius, Fn&& fn) const;
  /// Keypoint i's descriptor as four 64-bit words.
  const uint64_t* descriptor(int i) const { return &descriptors_[4 * static_cast<size_t>(i)]; }

 private:
  struct Entry {  ///< one keypoint in its cell: pixel position and index into the features
    double x, y;
    int index;
  };
  int cell_, cols_, rows_;
  std::vector<size_t> start_;   ///< cell c's entries are [start_[c], start_[c + 1])
  std::vector<Entry> entries_;  ///< grouped by cell (row-major), ascending index within a cell
  std::vector<uint64_t> descriptors_;
};

template <class Fn>
inline void FeatureGrid::forEachNear(double x, double y, double radius, Fn&& fn) const {
  const int x0 = std::max(0, static_cast<int>((x - radius) / cell_));
  const int x1 = std::min(cols_ - 1, static_cast<int>((x + radius) / cell_));
  const int y0 = std::max(0, static_cast<int>((y - radius) / cell_));
  const int y1 = std::min(rows_ - 1, static_cast<int>((y + radius) / cell_));
  const double r2 = radius * radius;
  for (int cy = y0; cy <= y1; ++cy)
    for (int cx = x0; cx <= x1; ++cx) {
      const size_t c = static_cast<size_t>(cy) * static_cast<size_t>(cols_) + static_cast<size_t>(cx);
      for (size_t i = start_[c]; i < start_[c + 1]; ++i) {
        const Entry& e = entries_[i];
        if ((e.x - x) * (e.x - x) + (e.y - y) * (e.y - y) <= r2) fn(e.index);
      }
    }
}

/// Matches keyframe features with depth to current keypoints near their projection under T_cur_kf.
/// One-to-one on the current side (the closest descriptor wins).
std::vector<FeatureMatch> matchByProjection(const FrameFeatures& cur, const FeatureGrid& grid,
                                            const FrameFeatures& kf, const SE3& T_cur_kf,
                                            const PinholeCamera& camera, const GuidedMatchConfig& config);

}  // namespace rgbdmap
