#pragma once
// Closed-form rigid alignment of corresponding 3-D point sets (Horn / Umeyama / Kabsch via SVD).
#include <optional>
#include <vector>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// Finds T_dst_src minimising sum w_i |dst_i - T * src_i|^2 (no scale). `weights` may be null (all 1).
/// Returns nullopt for fewer than 3 points, non-finite input or a degenerate (collinear) configuration.
std::optional<SE3> alignPointSets(const Vec3* src, const Vec3* dst, size_t n,
                                  const double* weights = nullptr);

inline std::optional<SE3> alignPointSets(const std::vector<Vec3>& src, const std::vector<Vec3>& dst) {
  if (src.size() != dst.size()) return std::nullopt;
  return alignPointSets(src.data(), dst.data(), src.size());
}

}  // namespace rgbdmap
