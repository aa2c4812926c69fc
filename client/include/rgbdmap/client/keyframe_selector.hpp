#pragma once
// Keyframe rule of Hu et al. 2017 (Sec. 3.1): similarity S = 2N / (N_t + N_k) between the current frame
// (N_t features) and the last keyframe (N_k features) with N matched; a new keyframe when S < P, or after
// at most m frames, or (our addition) when the motion from the keyframe is large. The odometry counts as N_k
// the keyframe's features with depth: only those can match (a 3-D point is needed), so a keyframe whose
// depth is sparser is not left sooner for that.
#include <string>

#include "rgbdmap/client/odometry_config.hpp"
#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

struct KeyframeDecision {
  bool new_keyframe = false;
  double similarity = 0.0;
  std::string reason;  ///< "similarity", "frame_gap", "motion" or empty
};

double similarity(int matched, int n_current, int n_keyframe);

KeyframeDecision decideKeyframe(int matched, int n_current, int n_keyframe, int frames_since_keyframe,
                                const SE3& T_kf_cur, const KeyframeConfig& config);

}  // namespace rgbdmap
