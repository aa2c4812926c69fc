#pragma once
// Matching by projection: with a pose estimate, a keyframe's 3-D points are projected into the current
// image and compared only with the current keypoints nearby. Used to add a window of keyframes to a pose
// that brute-force matching against the reference keyframe already found (ORB-SLAM's local-map idea).
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
  /// One keypoint in its cell: pixel position and index into the features.
  struct Entry {
    double x, y;
    int index;
  };

  FeatureGrid(const FrameFeatures& features, int width, int height, int cell_px = 16);
  /// Indices of keypoints within `radius` of (x, y) (cell-level candidates, exact distance checked), in
  /// row-major cell order and ascending index within a cell.
  void query(double x, double y, double radius, std::vector<int>* out) const;

  /// The cells overlapping the square of half-size `radius` around (x, y): [x0, x1] x [y0, y1].
  struct CellRange {
    int x0, x1, y0, y1;
  };
  CellRange cellsAround(double x, double y, double radius) const;
  /// The entries of cell (cx, cy): [begin, end).
  const Entry* cellBegin(int cx, int cy) const { return &entries_[start_[cy * cols_ + cx]]; }
  const Entry* cellEnd(int cx, int cy) const { return entries_.data() + start_[cy * cols_ + cx + 1]; }
  /// Keypoint i's descriptor as four 64-bit words.
  const uint64_t* descriptor(int i) const { return &descriptors_[4 * static_cast<size_t>(i)]; }

 private:
  int cell_, cols_, rows_;
  std::vector<size_t> start_;     ///< cell c's entries are [start_[c], start_[c + 1])
  std::vector<Entry> entries_;    ///< grouped by cell (row-major), ascending index within a cell
  std::vector<uint64_t> descriptors_;
};

/// Matches keyframe features with depth to current keypoints near their projection under T_cur_kf.
/// One-to-one on the current side (the closest descriptor wins).
std::vector<FeatureMatch> matchByProjection(const FrameFeatures& cur, const FeatureGrid& grid,
                                            const FrameFeatures& kf, const SE3& T_cur_kf,
                                            const PinholeCamera& camera, const GuidedMatchConfig& config);

}  // namespace rgbdmap
