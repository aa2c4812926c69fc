// The viewer's publisher thread: waits for the MapView to change (or a client to want a snapshot) and
// publishes what changed. Voxels: a delta against the set last published on /R/voxel_delta (a full
// snapshot when a client waits for one, every snapshot_period_s, or when the map was rebuilt so that most
// of it changed), and a PointCloud of all of them at most every cloud_period_s.
#include <cmath>

#include "viewer_impl.hpp"

namespace rgbdmap::viewer {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Voxel centre -> a key of its cell (21 bits per axis, offset so that +-52 km fit at 5 cm).
uint64_t voxelKey(const Voxel& v, double resolution) {
  auto cell = [&](float x) {
    return static_cast<uint64_t>(std::floor(x / resolution) + (1 << 20)) & 0x1fffff;
  };
  return (cell(v.x) << 42) | (cell(v.y) << 21) | cell(v.z);
}

json flat(const std::vector<Voxel>& voxels) {
  json a = json::array();
  for (const Voxel& v : voxels) {
    a.push_back(std::round(v.x * 1000.0f) / 1000.0f);
    a.push_back(std::round(v.y * 1000.0f) / 1000.0f);
    a.push_back(std::round(v.z * 1000.0f) / 1000.0f);
  }
  return a;
}

}  // namespace

void Viewer::Impl::send(uint32_t channel, const json& message, int64_t utime) {
  auto payload = std::make_shared<const std::string>(message.dump());
  if (recording) {
    // log_time: when recorded (this thread's clock, never backwards); publish_time: the message's own stamp
    // (a slice or a map carries the server's, older than the poses published meanwhile).
    const auto it = recorded_channels.find(channel);
    const uint64_t published_ns = static_cast<uint64_t>(std::max<int64_t>(0, utime)) * 1000u;
    recorded_ns = std::max(recorded_ns, static_cast<uint64_t>(nowUtime()) * 1000u);
    if (it != recorded_channels.end() &&
        recording->write({it->second, static_cast<uint32_t>(recorded_messages), recorded_ns, published_ns,
                          std::vector<uint8_t>(payload->begin(), payload->end())})) {
      ++recorded_messages;
    } else if (it != recorded_channels.end()) {
      recording_failed = true;  // a full disk: the file is dropped on stop, the error logged then
    }
  }
  server->publishLatest(channel, std::move(payload), utime);
}

void Viewer::Impl::run() {
  uint64_t seen = 0;
  while (!stopping) {
    seen = view.waitForChange(seen, 0.25);
    if (stopping) break;
    for (size_t i = 0; i < channels.size(); ++i) {
      const bool periodic = secondsSince(published[i]->last_snapshot) >= options.snapshot_period_s;
      publishRobot(i, periodic);
    }
  }
}

void Viewer::Impl::publishRobot(size_t index, bool periodic_snapshot) {
  RobotPublished& p = *published[index];
  const RobotSnapshot s = view.snapshot(view.robots()[index]);
  publishVoxels(index, s, periodic_snapshot);
  bool live = false;
  (void)currentPose(s, nowUtime(), &live);
  const bool trajectory = s.pose_changes != p.seen.pose_changes;
  if (trajectory || s.live_changes != p.seen.live_changes || live != p.live_used) {
    p.live_used = live;
    publishPoses(index, s, trajectory);
    publishTransforms();
  }
  publishMapGrid(index, s);
  if (s.loop_changes != p.seen.loop_changes)
    send(channels[index].loops, loopEdgesJson(s.loops, nowUtime(), "map", view.robots()[index] + "/loops"),
         nowUtime());
  if (s.slice_changes != p.seen.slice_changes && s.slice)
    send(channels[index].slice, gridJson(*s.slice, "map"), s.slice->header.utime);
  if (s.status_changes != p.seen.status_changes || s.map_changes != p.seen.map_changes ||
      secondsSince(p.last_status) >= 1.0)
    publishStatus(index, s);
  p.seen = s;
}

void Viewer::Impl::publishVoxels(size_t index, const RobotSnapshot& s, bool periodic_snapshot) {
  RobotPublished& p = *published[index];
  const uint32_t delta_channel = channels[index].voxel_delta;
  const bool changed = s.map_changes != p.seen.map_changes;
  const bool wanted = p.snapshot_wanted.exchange(false) || server->wantsSnapshot(delta_channel);
  const int64_t utime = nowUtime();
  if (changed) {
    int64_t map_revision = 0;
    std::vector<Voxel> voxels = view.occupiedVoxels(view.robots()[index], &map_revision);
    std::unordered_set<uint64_t> keys;
    keys.reserve(voxels.size());
    std::vector<Voxel> added, removed;
    for (const Voxel& v : voxels) {
      const uint64_t k = voxelKey(v, s.resolution_m);
      keys.insert(k);
      if (!p.voxel_keys.count(k)) added.push_back(v);
    }
    for (const Voxel& v : p.voxels)
      if (!keys.count(voxelKey(v, s.resolution_m))) removed.push_back(v);
    p.voxel_keys = std::move(keys);
    p.voxels = std::move(voxels);
    voxels_total = 0;
    for (const auto& q : published) voxels_total += q->voxels.size();
    ++p.revision;
    if (added.size() + removed.size() > p.voxels.size() / 2) {
      periodic_snapshot = true;  // mostly new (a rebuild after a loop closure): everyone gets a snapshot
    } else {
      const json delta = {{"revision", p.revision},
                          {"full", false},
                          {"resolution", s.resolution_m},
                          {"frame_id", "map"},
                          {"add", flat(added)},
                          {"remove", flat(removed)},
                          {"voxels", p.voxels.size()},
                          {"map_utime", s.map_utime},
                          {"robot_keyframe", s.map_keyframe_id}};
      server->publishDelta(delta_channel, std::make_shared<const std::string>(delta.dump()), utime);
    }
    p.cloud_pending = true;
    p.grid_pending = true;
  }
  if (periodic_snapshot || wanted) {
    const json snapshot = {{"revision", p.revision},
                           {"full", true},
                           {"resolution", s.resolution_m},
                           {"frame_id", "map"},
                           {"add", flat(p.voxels)},
                           {"remove", json::array()},
                           {"voxels", p.voxels.size()},
                           {"map_utime", s.map_utime},
                           {"robot_keyframe", s.map_keyframe_id}};
    server->publishSnapshot(delta_channel, std::make_shared<const std::string>(snapshot.dump()), utime,
                            periodic_snapshot);
    if (periodic_snapshot) p.last_snapshot = Clock::now();
  }
  if (p.cloud_pending && secondsSince(p.last_cloud) >= options.cloud_period_s) {
    send(channels[index].voxels, pointCloudJson(p.voxels, utime, "map"), utime);
    p.last_cloud = Clock::now();
    p.cloud_pending = false;
  }
}

void Viewer::Impl::publishStatus(size_t index, const RobotSnapshot& s) {
  RobotPublished& p = *published[index];
  const double dt = std::max(1e-3, secondsSince(p.last_status));
  const double kbps = 8e-3 * static_cast<double>(s.bytes_down - p.bytes_down_at_last_status) / dt;
  p.bytes_down_at_last_status = s.bytes_down;
  p.last_status = Clock::now();
  const int64_t utime = nowUtime();
  const double last_seen =
      s.last_seen_utime > 0 ? 1e-6 * static_cast<double>(utime - s.last_seen_utime) : -1.0;
  const json status = {{"robot", view.robots()[index]},
                       {"keyframes", s.status ? s.status->keyframes : static_cast<int>(s.keyframes.size())},
                       {"loops", s.status ? s.status->loop_closures : 0},
                       {"map_revision", s.map_revision},
                       {"voxels", p.voxels.size()},
                       {"bytes_down", s.bytes_down},
                       {"down_kbps", kbps},
                       {"last_seen_s", last_seen},
                       {"live_poses", s.live_changes},
                       {"spool_depth", s.link ? s.link->spool_depth : -1},
                       {"oldest_unanswered_s", s.link ? s.link->oldest_unanswered_s : 0.0},
                       {"live_only", s.link && s.link->live_only},
                       {"link", s.link ? s.link->diagnosis : std::string()},
                       {"state", s.server_state.empty() ? "no status" : s.server_state},
                       // "map" or "localize" ("" before the server's status names the robot); placed: its
                       // pose is in the map (a localising robot not placed yet: "unplaced")
                       {"map_mode", s.status ? (s.status->localize ? "localize" : "map") : ""},
                       {"placed", s.status && s.status->placed}};
  send(channels[index].status, status, utime);
}

}  // namespace rgbdmap::viewer
