#include "rgbdmap/client/keyframe_selector.hpp"

#include <cmath>

namespace rgbdmap {

double similarity(int matched, int n_current, int n_keyframe) {
  const int total = n_current + n_keyframe;
  return total > 0 ? 2.0 * matched / total : 0.0;
}

KeyframeDecision decideKeyframe(int matched, int n_current, int n_keyframe, int frames_since_keyframe,
                                const SE3& T_kf_cur, const KeyframeConfig& config) {
  KeyframeDecision d;
  d.similarity = similarity(matched, n_current, n_keyframe);
  const double rot_deg = se3::rotationAngle(T_kf_cur) * 180.0 / M_PI;
  if (d.similarity < config.similarity_threshold)
    d.reason = "similarity";
  else if (frames_since_keyframe >= config.max_frame_gap)
    d.reason = "frame_gap";
  else if (T_kf_cur.translation().norm() > config.max_translation_m || rot_deg > config.max_rotation_deg)
    d.reason = "motion";
  d.new_keyframe = !d.reason.empty();
  return d;
}

}  // namespace rgbdmap
