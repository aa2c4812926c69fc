#include "rgbdmap/intake/robot_registry.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {
namespace {

constexpr const char* kFileName = "robots.txt";
/// v2 added the camera mount (T_base_camera); a v1 line (without it) reads as the default mount. v3 added the
/// camera's rolling-shutter readout; a line without it reads as 0, the model the server had then.
constexpr const char* kHeader =
    "# rgbdmap robots v3: id index fx fy cx cy width height k1 k2 p1 p2 k3 depth_scale tx ty tz qx qy qz qw "
    "readout_s";

bool sameMount(const SE3& a, const SE3& b) { return a.matrix() == b.matrix(); }

/// The optional mount and readout at the end of a robots.txt line: no mount (v1) -> the default mount, no
/// readout (v1, v2) -> 0; partial, invalid or more -> false.
bool readTail(std::istringstream& f, SE3* T_base_camera, double* readout_s) {
  double v[8];
  int n = 0;
  while (n < 8 && f >> v[n]) ++n;
  std::string more;
  if (n < 8 ? !f.eof() : static_cast<bool>(f >> more)) return false;  // a word, or more than 8 numbers
  *readout_s = n == 8 ? v[7] : 0.0;
  if (n == 0) {
    *T_base_camera = defaultT_base_camera();
    return true;
  }
  if (n < 7 || !(std::abs(Eigen::Vector4d(v[3], v[4], v[5], v[6]).norm() - 1.0) <= 1e-6)) return false;
  *T_base_camera = se3::fromTum(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
  return se3::isValid(*T_base_camera, 1e-6);
}

}  // namespace

RobotRegistry::Entry& RobotRegistry::entry(const std::string& robot_id) {
  Entry& e = robots_[robot_id];
  e.stats.robot_id = robot_id;
  return e;
}

Result<bool> RobotRegistry::hello(const std::string& robot_id, int64_t session,
                                  const CameraIntrinsics& camera, const SE3& T_base_camera, bool localize) {
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& e = entry(robot_id);
  if (e.index < 0) e.index = next_index_++;
  if (e.stats.camera && !sameIntrinsics(*e.stats.camera, camera))
    log::warn("server: robot ", robot_id, " reports a different camera from now on");
  e.stats.camera = camera;
  // New chains of the robot start with the mount; keyframes already in the graph keep their poses.
  e.T_base_camera = T_base_camera;
  e.localize = localize;
  if (session > e.session) {
    e.session = session;
    ++e.stats.sessions;
  }
  if (localize) return false;
  const bool changed = !e.persisted || !sameIntrinsics(e.persisted->first, camera) ||
                       !sameMount(e.persisted->second, T_base_camera);
  e.persisted = std::make_pair(camera, T_base_camera);
  return changed;
}

bool RobotRegistry::localizing(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = robots_.find(robot_id);
  return it != robots_.end() && it->second.localize;
}

void RobotRegistry::noteSession(const std::string& robot_id, int64_t session) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = robots_.find(robot_id);
  if (it == robots_.end() || it->second.index < 0 || session <= it->second.session) return;
  it->second.session = session;
  ++it->second.stats.sessions;
}

Status RobotRegistry::save(const std::string& map_dir) const {
  std::ostringstream out;
  out << kHeader << "\n" << std::setprecision(17);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<const Entry*> ordered;
    for (const auto& [id, e] : robots_)
      if (e.index >= 0 && e.persisted) ordered.push_back(&e);
    std::sort(ordered.begin(), ordered.end(),
              [](const Entry* a, const Entry* b) { return a->index < b->index; });
    for (const Entry* e : ordered) {
      const CameraIntrinsics& c = e->persisted->first;
      const SE3& T_base_camera = e->persisted->second;
      out << e->stats.robot_id << " " << e->index << " " << c.fx << " " << c.fy << " " << c.cx << " " << c.cy
          << " " << c.width << " " << c.height;
      for (const double d : c.distortion) out << " " << d;
      const Vec3 t = T_base_camera.translation();
      const Eigen::Quaterniond q = se3::quat(T_base_camera);
      out << " " << c.depth_scale << " " << t.x() << " " << t.y() << " " << t.z() << " " << q.x() << " "
          << q.y() << " " << q.z() << " " << q.w() << " " << c.readout_s << "\n";
    }
  }
  return writeFileAtomic(map_dir + "/" + kFileName, out.str());
}

Status RobotRegistry::load(const std::string& map_dir) {
  const std::string path = map_dir + "/" + kFileName;
  std::ifstream in(path);
  if (!in) return Status::success();
  std::lock_guard<std::mutex> lock(mutex_);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream f(line);
    std::string id;
    int index = -1;
    CameraIntrinsics c;
    f >> id >> index >> c.fx >> c.fy >> c.cx >> c.cy >> c.width >> c.height;
    for (double& d : c.distortion) f >> d;
    f >> c.depth_scale;
    SE3 T_base_camera;
    if (!f || index < 0 || robots_.count(id) || !readTail(f, &T_base_camera, &c.readout_s) ||
        !c.validate().empty())
      return Status::failure(path + ":" + std::to_string(number) + ": unreadable robot line");
    Entry& e = entry(id);
    e.index = index;
    e.stats.camera = c;
    e.T_base_camera = T_base_camera;
    e.persisted = std::make_pair(c, T_base_camera);
    next_index_ = std::max(next_index_, index + 1);
  }
  return Status::success();
}

int RobotRegistry::index(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = robots_.find(robot_id);
  return it == robots_.end() ? -1 : it->second.index;
}

std::optional<CameraIntrinsics> RobotRegistry::camera(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = robots_.find(robot_id);
  return it == robots_.end() ? std::nullopt : it->second.stats.camera;
}

SE3 RobotRegistry::mount(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = robots_.find(robot_id);
  return it == robots_.end() ? defaultT_base_camera() : it->second.T_base_camera;
}

int64_t RobotRegistry::currentSession(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = robots_.find(robot_id);
  return it == robots_.end() ? 0 : it->second.session;
}

void RobotRegistry::addBytesReceived(const std::string& robot_id, size_t bytes, int64_t utime) {
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& e = entry(robot_id);
  e.stats.bytes_received += bytes;
  e.stats.last_utime = std::max(e.stats.last_utime, utime);
}

void RobotRegistry::addBytesSent(const std::string& robot_id, size_t bytes) {
  std::lock_guard<std::mutex> lock(mutex_);
  entry(robot_id).stats.bytes_sent += bytes;
}

void RobotRegistry::recordKeyframe(const std::string& robot_id, KeyframeOutcome outcome) {
  std::lock_guard<std::mutex> lock(mutex_);
  ServerRobotStats& s = entry(robot_id).stats;
  switch (outcome) {
    case KeyframeOutcome::kPlaced:
      ++s.keyframes;
      return;
    case KeyframeOutcome::kDuplicate:
      ++s.duplicates;
      return;
    case KeyframeOutcome::kRefused:
      ++s.keyframes_refused;
      return;
    case KeyframeOutcome::kRefusedBeforeDecode:
      ++s.refused_before_decode;
      return;
    case KeyframeOutcome::kOutOfOrder:
      ++s.out_of_order;
      return;
    case KeyframeOutcome::kChainSplit:
      ++s.chain_splits;
      return;
    case KeyframeOutcome::kWaitingForHello:
      ++s.waiting_for_hello;
      return;
    case KeyframeOutcome::kQueueFull:
      ++s.queue_full;
      return;
    case KeyframeOutcome::kDuplicateQueued:
      ++s.duplicates_queued;
      return;
    case KeyframeOutcome::kThrottled:
      ++s.throttled;
      return;
  }
}

void RobotRegistry::countLoop(const std::string& robot_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++entry(robot_id).stats.loops;
}

void RobotRegistry::noteHeartbeat(const msg::Heartbeat& heartbeat,
                                  std::chrono::steady_clock::time_point now) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = robots_.find(heartbeat.robot_id);
  if (it == robots_.end() || it->second.index < 0) return;
  std::optional<HeartbeatSeen>& seen = it->second.heartbeat;
  const bool same = seen && seen->session == heartbeat.header.session &&
                    seen->segment == heartbeat.segment_id &&
                    seen->last_keyframe_id == heartbeat.last_keyframe_id;
  const auto since = same ? seen->naming_since : now;
  seen =
      HeartbeatSeen{heartbeat.header.session, heartbeat.segment_id, heartbeat.last_keyframe_id, now, since};
}

std::map<std::string, RobotRegistry::HeartbeatSeen> RobotRegistry::heartbeats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<std::string, HeartbeatSeen> out;
  for (const auto& [id, e] : robots_)
    if (e.heartbeat) out.emplace(id, *e.heartbeat);
  return out;
}

std::vector<ServerRobotStats> RobotRegistry::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::pair<int, ServerRobotStats>> ordered;
  for (const auto& [id, e] : robots_)
    if (e.index >= 0) ordered.emplace_back(e.index, e.stats);
  std::sort(ordered.begin(), ordered.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<ServerRobotStats> out;
  for (auto& [i, s] : ordered) out.push_back(std::move(s));
  for (ServerRobotStats& s : out) s.mode = robots_.at(s.robot_id).localize ? "localize" : "map";
  return out;
}

}  // namespace rgbdmap
