#include "rgbdmap/workers/status_publisher.hpp"

#include <set>
#include <string>
#include <utility>

namespace rgbdmap {

StatusPublisher::StatusPublisher(double period_s, RobotRegistry& registry, RobotPublisher& publisher,
                                 std::function<int64_t()> graph_revision)
    : period_s_(period_s),
      registry_(registry),
      publisher_(publisher),
      graph_revision_(std::move(graph_revision)),
      worker_(SerialWorkerOptions{"rgbdmap-status", 0, period_s, [this] { publish(); }}) {}

void StatusPublisher::setRejectCounts(std::function<std::vector<msg::RejectCount>()> reject_counts) {
  reject_counts_ = std::move(reject_counts);
}

void StatusPublisher::setStateSource(std::function<std::string()> state) { state_ = std::move(state); }

void StatusPublisher::setPlacementSource(std::function<std::map<std::string, bool>()> placed) {
  placed_ = std::move(placed);
}

void StatusPublisher::start() {
  if (period_s_ > 0.0) worker_.start();
}

void StatusPublisher::stop() { worker_.stop(); }

msg::ServerStatus StatusPublisher::status() const {
  msg::ServerStatus status;
  status.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  status.graph_revision = graph_revision_();
  const std::map<std::string, bool> placed = placed_ ? placed_() : std::map<std::string, bool>{};
  for (const ServerRobotStats& r : registry_.stats()) {
    msg::RobotStatus s;
    s.robot_id = r.robot_id;
    s.keyframes = r.keyframes;
    s.loop_closures = r.loops;
    s.rejected_messages = static_cast<int64_t>(r.keyframes_refused);
    s.last_utime = r.last_utime;
    s.localize = r.mode == "localize";
    const auto it = placed.find(r.robot_id);
    s.placed = it == placed.end() || it->second;
    status.robots.push_back(s);
  }
  status.state = state_ ? state_() : "running";
  if (reject_counts_) status.rejects = reject_counts_();
  return status;
}

void StatusPublisher::publish() {
  const msg::ServerStatus s = status();
  std::set<std::string> sent;
  for (const msg::RobotStatus& robot : s.robots)
    if (sent.insert(robot.robot_id).second) publisher_.publish(robot.robot_id, s);
  for (const msg::RejectCount& r : s.rejects)  // known robots only (RejectLedger), bounded by the status
    if (!r.robot_id.empty() && sent.insert(r.robot_id).second) publisher_.publish(r.robot_id, s);
}

}  // namespace rgbdmap
