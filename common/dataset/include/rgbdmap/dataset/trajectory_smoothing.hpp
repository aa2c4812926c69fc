#pragma once
// Fixed-interval smoothing of a finished trajectory with a local quadratic in time (Savitzky-Golay over a
// time window): a camera carried by a robot or a hand moves smoothly at frame rate, while each frame's pose
// estimate carries its own measurement noise.
#include <vector>

#include "rgbdmap/dataset/trajectory.hpp"

namespace rgbdmap {

struct SmoothingInput {
  int segment = 0;     ///< poses of different segments never enter one fit (a tracking loss, a restart)
  bool usable = true;  ///< false: not a measurement (e.g. a lost frame's held pose); kept as it is
};

/// Each usable pose replaced by the value, at its own time, of the least-squares quadratic in time through
/// the usable poses of its segment within +-half_window_s: positions directly, rotations in the tangent
/// space at the pose's own rotation (R exp(fit at 0) over log(R^T R_j)). A quadratic keeps constant
/// acceleration exactly; where the window holds fewer than 3 distinct times the degree drops (one pose: as
/// it is). `inputs` parallel to it (empty: one segment, all
/// usable). A non-finite pose counts as unusable; half_window_s <= 0 or a non-finite stamp returns the poses
/// unchanged.
Trajectory smoothTrajectory(const Trajectory& poses, const std::vector<SmoothingInput>& inputs,
                            double half_window_s);

/// Each unusable pose (a lost frame's held prediction) replaced by the interpolation in time between the
/// nearest usable poses before and after it (se3::interpolate: the position on the straight line, the
/// rotation by the geodesic), across segments too: where tracking came back in a new segment, both ends
/// are in the frame the caller gives (the final map), while a prediction held over the gap drifts
/// unboundedly. A gap with no usable pose on one side (the start or end of the run) stays as it is.
/// `inputs` parallel to the poses (empty or another size: all usable, nothing changes); a non-finite
/// pose counts as unusable; a non-finite stamp returns the poses unchanged.
Trajectory bridgeUnusable(const Trajectory& poses, const std::vector<SmoothingInput>& inputs);

}  // namespace rgbdmap
