#include "rgbdmap/link/keyframe_replay.hpp"

#include <algorithm>
#include <chrono>
#include <set>
#include <thread>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/sample_reservoir.hpp"
#include "wall_clock.hpp"

namespace rgbdmap {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

size_t ReplayResult::acked() const {
  return static_cast<size_t>(std::count_if(keyframes.begin(), keyframes.end(),
                                           [](const ReplayedKeyframe& k) { return k.ack_ms >= 0; }));
}

double ReplayResult::ackQuantileMs(double q, double from_s, double to_s) const {
  std::vector<double> v;
  for (const ReplayedKeyframe& k : keyframes)
    if (k.ack_ms >= 0 && k.sent_s >= from_s && k.sent_s < to_s) v.push_back(k.ack_ms);
  return quantileOf(std::move(v), q);
}

ReplayResult replayKeyframes(const KeyframeStream& stream, RobotLink& link, const ReplayOptions& options) {
  ReplayResult result;
  const auto& kfs = stream.keyframes;
  if (kfs.empty()) return result;
  int max_id = 0, max_segment = 0;
  for (const msg::Keyframe& k : kfs) {
    max_id = std::max(max_id, k.keyframe_id);
    max_segment = std::max(max_segment, k.segment_id);
  }
  const double span_s = kfs.back().timestamp - kfs.front().timestamp;
  const double step_s = kfs.size() > 1 ? span_s / static_cast<double>(kfs.size() - 1) : 1.0;
  const double pass_s = span_s + step_s;  // a pass's timestamps start one mean step after the last one's end
  const Clock::time_point t0 = Clock::now();
  std::vector<int64_t> sent_wall;  // per result.keyframes entry
  size_t index = options.start % kfs.size(), sent = 0;
  double first_stamp = -1.0;
  std::set<int> sent_this_pass;
  bool over = false;
  for (size_t pass = 0; !over && !result.stopped && (pass == 0 || options.duration_s > 0.0);
       ++pass, index = 0) {
    sent_this_pass.clear();
    for (; index < kfs.size(); ++index) {
      msg::Keyframe k = kfs[index];
      const double stamp = k.timestamp + static_cast<double>(pass) * pass_s;
      if (first_stamp < 0) first_stamp = stamp;
      // Due times come from the schedule, not the clock: how many keyframes a duration holds does not
      // depend on the machine's load (a slow machine sends them late and reports the longer wall time).
      const double due_s =
          options.rate_hz > 0 ? static_cast<double>(sent) / options.rate_hz : stamp - first_stamp;
      if (options.duration_s > 0 && due_s >= options.duration_s) {
        over = true;
        break;
      }
      const Clock::time_point due =
          t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(due_s));
      if (options.stop ? options.stop->waitUntil(due) : (std::this_thread::sleep_until(due), false)) {
        result.stopped = true;
        break;
      }
      result.passes = pass + 1;
      const int id_offset = options.first_keyframe_id + static_cast<int>(pass) * (max_id + 1);
      const bool chained = k.previous_keyframe_id >= 0 && sent_this_pass.count(k.previous_keyframe_id) > 0;
      sent_this_pass.insert(k.keyframe_id);
      k.keyframe_id += id_offset;
      k.previous_keyframe_id = chained ? k.previous_keyframe_id + id_offset : -1;
      k.segment_id += options.first_segment + static_cast<int>(pass) * (max_segment + 1);
      k.timestamp = stamp;
      const int id = k.keyframe_id, segment = k.segment_id;
      const int64_t wall = nowUtime();
      const double sent_s = std::chrono::duration<double>(Clock::now() - t0).count();
      ++sent;
      if (Status s = link.sendKeyframeMessage(std::move(k)); !s) {
        ++result.send_failures;
        log::warn("replay: ", s.error());
        continue;
      }
      link.setTrackingState(id, segment, TrackingState::kTracking);
      result.keyframes.push_back({id, sent_s, -1.0});
      sent_wall.push_back(wall);
    }
  }
  if (!result.stopped) link.waitAllAcked(options.final_wait_s);
  const std::map<int, int64_t> acks = link.keyframeAckTimes();
  for (size_t i = 0; i < result.keyframes.size(); ++i) {
    const auto it = acks.find(result.keyframes[i].id);
    if (it != acks.end())
      result.keyframes[i].ack_ms = std::max(0.0, 1e-3 * static_cast<double>(it->second - sent_wall[i]));
  }
  result.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  result.link = link.stats();
  return result;
}

}  // namespace rgbdmap
