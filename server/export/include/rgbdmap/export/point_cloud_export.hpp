#pragma once
// Coloured point cloud of the map: voxel-downsampled accumulation of keyframe points, written as binary PLY.
// Points are in the map frame (z-up, REP-103: the base frame of the first robot's first keyframe).
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

struct ColoredPoint {
  Eigen::Vector3f p = Eigen::Vector3f::Zero();  ///< map frame, metres
  std::array<uint8_t, 3> rgb{0, 0, 0};          ///< red, green, blue
};

/// Voxel-downsamples (one averaged point and colour per voxel of `voxel_m`) and accumulates points given in
/// a keyframe's camera frame at T_map_cam. Memory is bounded by the number of occupied voxels (36 bytes of
/// sums per voxel plus the hash map's overhead), not by the number of points added.
class VoxelCloud {
 public:
  explicit VoxelCloud(double voxel_m);

  /// Adds points (camera frame) seen from T_map_cam. Non-finite points and points beyond the voxel index
  /// range (+-2^20 voxels per axis) are skipped and counted in skipped(). Fails, adding nothing, when the
  /// two vectors differ in size, the pose is not a rigid transform, or the voxel size is not a finite
  /// positive number.
  Status add(const std::vector<Eigen::Vector3f>& points_cam, const std::vector<std::array<uint8_t, 3>>& rgb,
             const SE3& T_map_cam);

  /// One point per voxel: the mean position and mean colour of what fell into it, sorted by voxel index
  /// (deterministic for the same input).
  std::vector<ColoredPoint> points() const;
  size_t size() const { return voxels_.size(); }
  size_t skipped() const { return skipped_; }
  double voxelSize() const { return voxel_m_; }

 private:
  struct Sum {
    double x = 0, y = 0, z = 0;
    uint32_t r = 0, g = 0, b = 0, n = 0;
  };
  double voxel_m_;
  std::unordered_map<uint64_t, Sum> voxels_;
  size_t skipped_ = 0;
};

/// Writes binary_little_endian PLY 1.0: one `vertex` element with `float x, y, z` and `uchar red, green,
/// blue` (15 bytes per point), read by MeshLab, CloudCompare, Open3D and PCL. The file appears atomically
/// (written beside, then renamed). Fails on a non-finite point or an I/O error.
Status writePly(const std::string& path, const std::vector<ColoredPoint>& points);

/// Reads what writePly writes (for tests and tools). Rejects other formats and property layouts, a
/// malformed header, a vertex count above 2^31, and a body shorter or longer than the header says.
Result<std::vector<ColoredPoint>> readPly(const std::string& path);

}  // namespace rgbdmap
