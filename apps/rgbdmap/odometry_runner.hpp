#pragma once
// Runs the visual odometry over a whole dataset and gathers what the commands write and report.
#include <string>
#include <vector>

#include "rgbdmap/cli/odometry_setup.hpp"
#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap::app {

struct OdometryRun {
  Trajectory trajectory;  ///< every frame, odometry frame
  Trajectory keyframes;   ///< keyframe poses in creation order
  int frames = 0, keyframe_count = 0, losses = 0, segments = 1, unreadable_frames = 0;
  int dropped_frames = 0;         ///< a live source's frames the odometry was too slow for
  std::string source_error;       ///< set: the source failed and the run ended there
  std::vector<StageTimes> times;  ///< per frame

  double medianMs(double StageTimes::*stage) const;
  double meanMs(double StageTimes::*stage) const;
  /// Multi-line human summary (frames, keyframes, losses, per-stage median/mean ms).
  std::string summary() const;
};

/// Processes the source's frames until it ends. Unreadable frames are logged, counted and skipped. Shows
/// progress on an interactive terminal.
OdometryRun runOdometry(FrameSource& source, const OdometrySetup& setup);

}  // namespace rgbdmap::app
