#pragma once
// Runs the robot: visual odometry over a dataset at its real frame rate (or as fast as possible), each new
// keyframe sent through a RobotLink, heartbeats kept current, and the trajectory expressed in the map frame
// with the corrections the server sent.
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <vector>

#include "rgbdmap/client/avoidance.hpp"
#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap {

/// A stop request another thread (e.g. a signal-handling thread) can raise; waits on it end at once.
class StopRequest {
 public:
  void request();
  bool requested() const;
  /// Sleeps until `deadline` or a request; true if stop was requested.
  bool waitUntil(std::chrono::steady_clock::time_point deadline) const;

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  bool requested_ = false;
};

struct RobotRunOptions {
  int first_frame = 0;   ///< runRobot(TumDataset...) only: a FrameSource comes with its own range
  int end_frame = -1;    ///< exclusive; -1 = all
  bool realtime = true;  ///< pace a recording by its timestamps (false: --fast); a live source paces itself
  double final_wait_s = 20.0;  ///< at the end: wait for every ack and a correction covering the last keyframe
  /// > 0: after each keyframe sent, wait up to this long for the server's correction covering it before the
  /// next frame. A recording run as fast as possible then meets the server in one order whatever the load
  /// (the server optimises after each keyframe), so the map does not depend on the machine's speed. A
  /// correction that does not come in time (a refused keyframe, a server gone) ends the waiting.
  double lockstep_s = 0.0;
  /// Called after each frame with (frames done, frames in the range); e.g. the CLI's progress line.
  std::function<void(int done, int total)> progress;
  const StopRequest* stop = nullptr;  ///< optional: ends the run early (outputs are still complete)
  /// Set: every frame, the reactive avoidance rule (Lin et al. 2017, section 3) runs on the link's latest
  /// slice at the live pose and its VelocityCommand is published through the link (cmd_vel). Off by default.
  std::optional<AvoidanceConfig> avoidance;
  /// The odometry's first keyframe id and segment (KeyframeSpool::firstKeyframeId/firstSegment: a robot
  /// resuming its spooled session continues above the numbers it used).
  int first_keyframe_id = 0, first_segment = 0;
  /// A stop (signal) still waits up to final_wait_s for the answers (a robot with a keyframe spool: what is
  /// not answered then stays spooled for the next start). false: a stop ends the run at once.
  bool final_wait_when_stopped = false;
};

/// One avoidance decision of runRobot (one per frame).
struct AvoidanceRecord {
  double timestamp = 0.0;  ///< the frame's
  AvoidanceState state = AvoidanceState::kForward;
  double closest_obstacle_m = 0.0;  ///< +inf: corridor clear; NaN: not evaluated (stopped)
  bool stopped = false;             ///< no usable slice (missing, stale) or invalid pose: zero command
};

struct AvoidanceSummary {
  int forward = 0, turn_left = 0, back_right = 0;  ///< decisions that drove, per state
  int stopped = 0;                                 ///< decisions that stopped the robot
  int commands_published = 0, commands_failed = 0;
  std::vector<AvoidanceRecord> decisions;
};

/// Per frame: what re-anchoring it on corrected keyframe poses needs.
struct RunFrameRecord {
  double timestamp = 0.0;
  SE3 T_odom_cam = SE3::Identity();
  int segment = 0;
  int reference_keyframe = -1;
  bool tracked = true;  ///< false: lost, the pose is the odometry's prediction
};
/// Per keyframe the odometry made.
struct RunKeyframeRecord {
  double timestamp = 0.0;
  SE3 T_odom_cam = SE3::Identity();
  int segment = 0;
};

struct RobotRunResult {
  /// Every frame, T_map_cam as known at that moment: mapFromOdom(segment) * T_odom_cam.
  Trajectory live;
  /// Every frame re-anchored on the final corrected keyframes of its segment: T_map_odom at the frame's time
  /// is interpolated by time between the corrections T_map_kf(final) * T_odom_kf^-1 of the keyframes before
  /// and after it (mapFromOdom(segment) when none is corrected); lost frames then placed between the tracked
  /// frames around them (bridgeUnusable); then, with trajectory_smoothing_s > 0, the tracked frames of each
  /// segment smoothed by smoothTrajectory.
  Trajectory final_map;
  double trajectory_smoothing_s = 0.0;  ///< OdometryConfig::trajectory_smoothing_s of the run
  Trajectory odometry;                  ///< every frame, odometry frame
  Trajectory keyframes_final;           ///< keyframe poses, final corrected (map frame)
  std::vector<StageTimes> times;
  int frames = 0, keyframes = 0, losses = 0, segments = 0, unreadable_frames = 0;
  int dropped_frames = 0;          ///< a live source's frames the odometry was too slow for (newest wins)
  std::string source_error;        ///< set: the source failed (device lost, truncated bag) and the run ended
  int keyframes_not_sent = 0;      ///< sendKeyframe failed (encoding, window full past the timeout, stopped)
  bool waited_for_server = false;  ///< lockstep_s > 0 and every correction came within it
  bool all_acked = false, final_correction_received = false;
  bool interrupted = false;  ///< options.stop ended the run
  RobotLinkStats link;
  std::map<int, int64_t> keyframe_ack_utime;  ///< RobotLink::keyframeAckTimes() at the end
  double wall_s = 0.0;
  std::optional<AvoidanceSummary> avoidance;  ///< when RobotRunOptions::avoidance was set

  std::vector<RunFrameRecord> frame_records;          ///< parallel to odometry
  std::map<int, RunKeyframeRecord> keyframe_records;  ///< by keyframe id

  /// Median of a per-frame stage time (ms); 0 without frames.
  double medianMs(double StageTimes::*stage = &StageTimes::total_ms) const;
};

/// Runs VisualOdometry over frames [first_frame, end_frame) of the dataset, sends each new keyframe through
/// `link` (which the caller has started), keeps heartbeats' tracking state current. Never throws; unreadable
/// frames are logged and counted.
/// Recomputes final_map and keyframes_final from the link's latest corrections: e.g. after the run, once
/// other robots' keyframes have merged the maps and the server sent newer corrections. runRobot calls it.
void reanchorFinalMap(const RobotLink& link, RobotRunResult* result);

RobotRunResult runRobot(const TumDataset& dataset, const CameraIntrinsics& camera,
                        const OdometryConfig& odometry, RobotLink& link, const RobotRunOptions& options);
/// The same over any frame source, until it ends (or options.stop; close() the source too to end a
/// blocking live read at once).
RobotRunResult runRobot(FrameSource& source, const CameraIntrinsics& camera, const OdometryConfig& odometry,
                        RobotLink& link, const RobotRunOptions& options);

}  // namespace rgbdmap
