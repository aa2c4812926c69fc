#pragma once
// Small helpers shared by the common library's tests.
#include <string>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap::testing {

inline bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

/// A rigid transform far from identity (rotation of ~1.2 rad, translation of ~2.9 m).
inline SE3 knownTransform() {
  Vec6 xi;
  xi << 0.7, -1.2, 2.5, 0.3, -0.5, 1.1;
  return se3::exp(xi);
}

}  // namespace rgbdmap::testing
