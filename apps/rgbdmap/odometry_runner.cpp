#include "odometry_runner.hpp"

#include <algorithm>
#include <cstdio>
#include <numeric>

#include "rgbdmap/cli/progress.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::app {

double OdometryRun::medianMs(double StageTimes::*stage) const {
  if (times.empty()) return 0;
  std::vector<double> v;
  for (const auto& t : times) v.push_back(t.*stage);
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double OdometryRun::meanMs(double StageTimes::*stage) const {
  if (times.empty()) return 0;
  double sum = 0;
  for (const auto& t : times) sum += t.*stage;
  return sum / times.size();
}

std::string OdometryRun::summary() const {
  char buf[512];
  std::snprintf(
      buf, sizeof buf,
      "frames %d, keyframes %d, tracking losses %d, segments %d, unreadable %d%s\n"
      "ms/frame median %.2f mean %.2f (%.1f frames/s); stage medians: extract %.2f, match %.2f, "
      "ransac %.2f, refine %.2f",
      frames, keyframe_count, losses, segments, unreadable_frames,
      dropped_frames ? (", dropped " + std::to_string(dropped_frames) + " (live source)").c_str() : "",
      medianMs(&StageTimes::total_ms), meanMs(&StageTimes::total_ms),
      1000.0 / std::max(1e-9, medianMs(&StageTimes::total_ms)), medianMs(&StageTimes::extract_ms),
      medianMs(&StageTimes::match_ms), medianMs(&StageTimes::ransac_ms), medianMs(&StageTimes::refine_ms));
  return buf;
}

OdometryRun runOdometry(FrameSource& source, const OdometrySetup& setup) {
  OdometryRun run;
  VisualOdometry vo(setup.camera, setup.odometry);
  Progress progress("odometry", source.sizeHint());
  log::RateLimiter limiter(1.0);
  for (size_t done = 1;; ++done) {
    const FrameRead read = source.next();
    if (read.kind == FrameRead::Kind::kEnd) break;
    if (read.kind == FrameRead::Kind::kFailed) {
      run.source_error = read.error;
      break;
    }
    if (read.kind == FrameRead::Kind::kUnreadable) {
      ++run.unreadable_frames;
      uint64_t suppressed = 0;
      if (limiter.allow(&suppressed))
        log::warn("skipping frame ", read.index, ": ", read.error, suppressed ? " (+" : "",
                  suppressed ? std::to_string(suppressed) + " more)" : "");
      continue;
    }
    const TrackingResult r = vo.track(read.frame);
    run.trajectory.push_back({r.timestamp, r.T_odom_cam});
    run.times.push_back(r.times);
    if (r.new_keyframe) run.keyframes.push_back({r.timestamp, r.T_odom_cam});
    run.segments = std::max(run.segments, r.segment + 1);
    progress.update(done);
  }
  progress.finish();
  run.frames = static_cast<int>(run.trajectory.size());
  run.keyframe_count = static_cast<int>(vo.keyframes().size());
  run.losses = vo.trackingLosses();
  run.dropped_frames = static_cast<int>(source.droppedFrames());
  return run;
}

}  // namespace rgbdmap::app
