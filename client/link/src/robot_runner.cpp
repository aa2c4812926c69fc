// runRobot: odometry over a frame source, keyframes through the RobotLink, trajectories in the map frame.
#include "rgbdmap/link/robot_runner.hpp"

#include <algorithm>
#include <exception>
#include <map>
#include <thread>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/dataset/trajectory_smoothing.hpp"

namespace rgbdmap {

void StopRequest::request() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    requested_ = true;
  }
  cv_.notify_all();
}

bool StopRequest::requested() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return requested_;
}

bool StopRequest::waitUntil(std::chrono::steady_clock::time_point deadline) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return cv_.wait_until(lock, deadline, [this] { return requested_; });
}

double RobotRunResult::medianMs(double StageTimes::*stage) const {
  if (times.empty()) return 0.0;
  std::vector<double> v;
  v.reserve(times.size());
  for (const StageTimes& t : times) v.push_back(t.*stage);
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

namespace {

using Clock = std::chrono::steady_clock;

using FrameRecord = RunFrameRecord;
using KeyframeRecord = RunKeyframeRecord;

struct RunState {
  std::vector<FrameRecord> frames;
  std::map<int, KeyframeRecord> keyframes;  ///< every keyframe the odometry made, by id
  int last_sent_keyframe = -1;
};

bool stopRequested(const RobotRunOptions& options) { return options.stop && options.stop->requested(); }

/// Waits until the frame's time relative to the first frame has passed on the wall clock; false if stopped.
bool paceFrame(const RobotRunOptions& options, Clock::time_point wall0, double dt_s) {
  const Clock::time_point deadline =
      wall0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(0.0, dt_s)));
  if (options.stop) return !options.stop->waitUntil(deadline);
  std::this_thread::sleep_until(deadline);
  return true;
}

void sendKeyframe(const TrackingResult& r, const RgbdFrame& frame, RobotLink& link, RunState* state,
                  RobotRunResult* out) {
  const Keyframe& kf = *r.new_keyframe;
  state->keyframes[kf.id] = {kf.timestamp, kf.T_odom_cam, kf.segment};
  if (Status s = link.sendKeyframe(kf, frame); !s) {
    ++out->keyframes_not_sent;
    log::warn("keyframe ", kf.id, " not sent: ", s.error());
    return;
  }
  state->last_sent_keyframe = kf.id;
}

double systemNowS() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

/// One avoidance step at the live pose: decide on the latest slice, publish the command, record it.
void avoid(AvoidanceController& controller, RobotLink& link, const StampedPose& live,
           AvoidanceSummary* summary) {
  const std::optional<msg::OccupancySlice> slice = link.latestSlice();
  const AvoidanceDecision d =
      controller.update(slice ? *slice : msg::OccupancySlice{}, live.T_world_cam, systemNowS());
  summary->decisions.push_back({live.timestamp, d.state, d.closest_obstacle_m, d.stopped});
  if (d.stopped)
    ++summary->stopped;
  else if (d.state == AvoidanceState::kForward)
    ++summary->forward;
  else if (d.state == AvoidanceState::kTurnLeft)
    ++summary->turn_left;
  else
    ++summary->back_right;
  if (link.publishCommand(controller.command(d, "")))
    ++summary->commands_published;
  else
    ++summary->commands_failed;
}

/// Counts and reports (rate-limited) a frame the source could not read.
void skipUnreadable(const FrameRead& read, log::RateLimiter* limiter, RobotRunResult* out) {
  ++out->unreadable_frames;
  uint64_t suppressed = 0;
  if (limiter->allow(&suppressed))
    log::warn("skipping frame ", read.index, ": ", read.error, " (", suppressed, " more)");
}

/// Tracks one frame: keyframe out through the link, tracking state, live pose, avoidance, records.
void trackFrame(const RgbdFrame& frame, VisualOdometry& vo, RobotLink& link, const RobotRunOptions& options,
                RunState* state, std::optional<AvoidanceController>& controller, int* last_keyframe,
                RobotRunResult* out) {
  const TrackingResult r = vo.track(frame);
  if (r.new_keyframe) {
    *last_keyframe = r.new_keyframe->id;
    sendKeyframe(r, frame, link, state, out);
    if (out->waited_for_server && state->last_sent_keyframe == r.new_keyframe->id &&
        !link.waitForCorrection(r.new_keyframe->id, options.lockstep_s) && !stopRequested(options)) {
      out->waited_for_server = false;
      log::warn("no correction for keyframe ", r.new_keyframe->id, " within ", options.lockstep_s,
                " s: the robot stops waiting for the server after each keyframe (the map may now depend "
                "on timing)");
    }
  }
  link.setTrackingState(*last_keyframe, r.segment, r.state);
  state->frames.push_back(
      {r.timestamp, r.T_odom_cam, r.segment, r.reference_keyframe, r.state != TrackingState::kLost});
  out->live.push_back({r.timestamp, link.mapFromOdom(r.segment) * r.T_odom_cam});
  if (r.state != TrackingState::kLost)
    if (const Status s =
            link.publishPose(r.timestamp, r.segment, r.reference_keyframe, r.state, r.T_odom_cam);
        !s)
      log::debug("live pose: ", s.error());
  if (controller) avoid(*controller, link, out->live.back(), &*out->avoidance);
  out->odometry.push_back({r.timestamp, r.T_odom_cam});
  out->times.push_back(r.times);
  out->segments = std::max(out->segments, r.segment - options.first_segment + 1);
}

/// Pulls frames until the source ends. A recording is paced by its timestamps when options.realtime; a
/// live source paces itself (next() waits for the sensor).
void trackFrames(FrameSource& source, VisualOdometry& vo, RobotLink& link, const RobotRunOptions& options,
                 RunState* state, RobotRunResult* out) {
  std::optional<AvoidanceController> controller;
  if (options.avoidance) {
    controller.emplace(*options.avoidance);
    out->avoidance.emplace();
  }
  const bool pace = options.realtime && !source.live();
  const int total = static_cast<int>(source.sizeHint());
  Clock::time_point wall0;
  std::optional<double> t0;
  log::RateLimiter limiter(1.0);
  int last_keyframe = -1, done = 0;
  for (;;) {
    if (stopRequested(options)) {
      out->interrupted = true;
      return;
    }
    const FrameRead read = source.next();
    if (read.kind == FrameRead::Kind::kEnd) return;
    if (read.kind == FrameRead::Kind::kFailed) {
      out->source_error = read.error;
      return;
    }
    ++done;
    if (read.kind == FrameRead::Kind::kUnreadable) {
      skipUnreadable(read, &limiter, out);
      continue;
    }
    if (pace) {
      if (!t0) t0 = read.frame.timestamp, wall0 = Clock::now();
      if (!paceFrame(options, wall0, read.frame.timestamp - *t0)) {
        out->interrupted = true;
        return;
      }
    }
    trackFrame(read.frame, vo, link, options, state, controller, &last_keyframe, out);
    if (options.progress) options.progress(done, std::max(total, done));
  }
}

/// Per segment, the corrected keyframes in time order with their corrections C = T_map_kf * T_odom_kf^-1.
using Corrections = std::map<int, std::vector<std::pair<double, SE3>>>;

Corrections keyframeCorrections(const std::map<int, KeyframeRecord>& keyframes, const RobotLink& link) {
  Corrections out;
  for (const auto& [id, kf] : keyframes)
    if (const std::optional<SE3> T_map_kf = link.correctedKeyframe(id))
      out[kf.segment].emplace_back(kf.timestamp, *T_map_kf * kf.T_odom_cam.inverse());
  for (auto& [segment, list] : out)
    std::sort(list.begin(), list.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

/// T_map_odom at the frame's time: the corrections of the keyframes before and after it in its segment,
/// interpolated by time (a keyframe's own frame gets exactly its optimised pose); the segment's newest
/// correction when there is none.
SE3 finalMapFromOdom(const FrameRecord& f, const Corrections& corrections, const RobotLink& link) {
  const auto it = corrections.find(f.segment);
  if (it == corrections.end() || it->second.empty()) return link.mapFromOdom(f.segment);
  const auto& list = it->second;
  const auto next = std::lower_bound(list.begin(), list.end(), f.timestamp,
                                     [](const auto& c, double t) { return c.first < t; });
  if (next == list.begin()) return next->second;
  if (next == list.end()) return list.back().second;
  const auto prev = std::prev(next);
  const double span = next->first - prev->first;
  const double alpha = span > 0.0 ? (f.timestamp - prev->first) / span : 1.0;
  return se3::interpolate(prev->second, next->second, alpha);
}

void finish(const RunState& state, RobotLink& link, const RobotRunOptions& options, RobotRunResult* out) {
  const bool any_sent = state.last_sent_keyframe >= 0;
  const bool any_pending = any_sent || link.stats().keyframes_pending > 0;  // also an earlier run's spooled
  const bool wait =
      any_pending && (options.final_wait_when_stopped || (!out->interrupted && !stopRequested(options)));
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(wait ? std::max(0.0, options.final_wait_s) : 0.0));
  auto remaining = [&] { return std::chrono::duration<double>(deadline - Clock::now()).count(); };
  out->all_acked = !any_pending || link.waitAllAcked(std::max(0.0, remaining()));
  out->final_correction_received =
      any_sent && link.waitForCorrection(state.last_sent_keyframe, std::max(0.0, remaining()));
  // A stop during the final wait (Ctrl-C once the frames ran out) also cut the run short.
  if (stopRequested(options)) out->interrupted = true;
  out->frame_records = state.frames;
  out->keyframe_records = state.keyframes;
  reanchorFinalMap(link, out);
}

}  // namespace

void reanchorFinalMap(const RobotLink& link, RobotRunResult* out) {
  out->final_map.clear();
  out->keyframes_final.clear();
  const Corrections corrections = keyframeCorrections(out->keyframe_records, link);
  std::vector<SmoothingInput> inputs;
  for (const FrameRecord& f : out->frame_records) {
    out->final_map.push_back(
        {f.timestamp, se3::normalized(finalMapFromOdom(f, corrections, link) * f.T_odom_cam)});
    inputs.push_back({f.segment, f.tracked});
  }
  out->final_map =
      smoothTrajectory(bridgeUnusable(out->final_map, inputs), inputs, out->trajectory_smoothing_s);
  for (const auto& [id, kf] : out->keyframe_records) {
    const std::optional<SE3> T_map_kf = link.correctedKeyframe(id);
    out->keyframes_final.push_back(
        {kf.timestamp, T_map_kf ? *T_map_kf : link.mapFromOdom(kf.segment) * kf.T_odom_cam});
  }
}

RobotRunResult runRobot(const TumDataset& dataset, const CameraIntrinsics& camera,
                        const OdometryConfig& odometry, RobotLink& link, const RobotRunOptions& options) {
  const std::unique_ptr<FrameSource> source =
      makeTumSource(dataset, static_cast<size_t>(std::max(0, options.first_frame)), options.end_frame);
  return runRobot(*source, camera, odometry, link, options);
}

RobotRunResult runRobot(FrameSource& source, const CameraIntrinsics& camera, const OdometryConfig& odometry,
                        RobotLink& link, const RobotRunOptions& options) {
  RobotRunResult out;
  out.waited_for_server = options.lockstep_s > 0.0;
  out.trajectory_smoothing_s = odometry.trajectory_smoothing_s;
  const Clock::time_point start = Clock::now();
  RunState state;
  try {
    VisualOdometry vo(camera, odometry, options.first_keyframe_id, options.first_segment);
    trackFrames(source, vo, link, options, &state, &out);
    out.losses = vo.trackingLosses();
  } catch (const std::exception& e) {
    log::error("robot run stopped after ", state.frames.size(), " frames: ", e.what());
    out.interrupted = true;
  }
  out.dropped_frames = static_cast<int>(source.droppedFrames());
  out.frames = static_cast<int>(state.frames.size());
  out.keyframes = static_cast<int>(state.keyframes.size());
  try {
    finish(state, link, options, &out);
  } catch (const std::exception& e) {
    log::error("robot run: final trajectories: ", e.what());
  }
  out.link = link.stats();
  out.keyframe_ack_utime = link.keyframeAckTimes();
  out.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  return out;
}

}  // namespace rgbdmap
