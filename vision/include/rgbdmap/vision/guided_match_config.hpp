#pragma once
// Configuration of matching by projection (see guided_matcher.hpp).
namespace rgbdmap {

struct GuidedMatchConfig {
  double radius_px = 10.0;  ///< search radius around the projection (scaled by the keypoint's octave)
  int max_distance = 50;    ///< Hamming distance accepted
  double ratio = 0.9;       ///< best vs second-best within the radius
};

}  // namespace rgbdmap
