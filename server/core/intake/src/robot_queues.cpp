#include "rgbdmap/intake/robot_queues.hpp"

#include <algorithm>
#include <utility>

namespace rgbdmap {

bool RobotQueues::hasRoom(const std::string& robot, size_t bytes) const {
  if (total_ >= limits_.keyframes_total) return false;
  const auto it = queues_.find(robot);
  if (it == queues_.end() || it->second.entries.empty()) return limits_.keyframes_per_robot > 0;
  const Queue& q = it->second;
  return q.entries.size() < limits_.keyframes_per_robot && q.bytes + bytes <= limits_.bytes_per_robot;
}

namespace {

bool sameKeyframe(const msg::Keyframe& a, const msg::Keyframe& b) {
  return a.keyframe_id == b.keyframe_id && a.segment_id == b.segment_id &&
         a.header.session == b.header.session;
}

}  // namespace

bool RobotQueues::contains(const std::string& robot, const msg::Keyframe& keyframe) const {
  const auto it = queues_.find(robot);
  if (it == queues_.end()) return false;
  // At most robot_queue_capacity (64) entries: a scan costs less than decoding the message did.
  return std::any_of(it->second.entries.begin(), it->second.entries.end(),
                     [&](const Entry& e) { return sameKeyframe(e.keyframe, keyframe); });
}

RobotQueues::Pushed RobotQueues::push(const std::string& robot, msg::Keyframe keyframe, size_t bytes) {
  if (contains(robot, keyframe)) return Pushed::kDuplicate;
  if (!hasRoom(robot, bytes)) return Pushed::kFull;
  Queue& q = queues_[robot];
  if (q.entries.empty()) turn_.push_back(robot);
  q.entries.push_back({std::move(keyframe), bytes});
  q.bytes += bytes;
  q.high_water = std::max(q.high_water, q.entries.size());
  ++total_;
  return Pushed::kQueued;
}

std::optional<msg::Keyframe> RobotQueues::pop(Clock::time_point now) {
  if (turn_.empty()) return std::nullopt;
  auto next = std::find_if(turn_.begin(), turn_.end(),
                           [&](const std::string& r) { return queues_[r].demoted_until <= now; });
  if (next == turn_.end()) next = turn_.begin();  // every robot with work is demoted: plain round-robin
  const std::string robot = std::move(*next);
  turn_.erase(next);
  Queue& q = queues_[robot];
  Entry entry = std::move(q.entries.front());
  q.entries.pop_front();
  q.bytes -= entry.bytes;
  --total_;
  if (!q.entries.empty()) turn_.push_back(robot);  // its next keyframe waits for every other robot's turn
  return std::move(entry.keyframe);
}

void RobotQueues::demote(const std::string& robot, Clock::time_point until) {
  Queue& q = queues_[robot];
  q.demoted_until = std::max(q.demoted_until, until);
}

void RobotQueues::clear() {
  for (auto& [robot, q] : queues_) {
    q.entries.clear();
    q.bytes = 0;
  }
  turn_.clear();
  total_ = 0;
}

size_t RobotQueues::size(const std::string& robot) const {
  const auto it = queues_.find(robot);
  return it == queues_.end() ? 0 : it->second.entries.size();
}

size_t RobotQueues::bytes(const std::string& robot) const {
  const auto it = queues_.find(robot);
  return it == queues_.end() ? 0 : it->second.bytes;
}

size_t RobotQueues::highWater(const std::string& robot) const {
  const auto it = queues_.find(robot);
  return it == queues_.end() ? 0 : it->second.high_water;
}

}  // namespace rgbdmap
