#include "rgbdmap/intake/hello_hold.hpp"

#include <algorithm>

namespace rgbdmap {

size_t HelloHold::bytesOf(const msg::Keyframe& kf) {
  return kf.images.color.size() + kf.images.depth.size() + kf.descriptors.size() +
         kf.keypoints.size() * sizeof(msg::KeyPoint) + sizeof(msg::Keyframe);
}

bool HelloHold::hold(msg::Keyframe kf) {
  const size_t bytes = bytesOf(kf);
  const bool room = robots_.count(kf.robot_id) > 0 || robots_.size() < kMaxRobots;
  if (bytes > max_bytes_per_robot_ || max_per_robot_ == 0 || !room) {
    ++dropped_;
    return false;
  }
  Robot& robot = robots_[kf.robot_id];
  const bool copy = std::any_of(robot.keyframes.begin(), robot.keyframes.end(), [&](const msg::Keyframe& k) {
    return k.header.session == kf.header.session && k.segment_id == kf.segment_id &&
           k.keyframe_id == kf.keyframe_id;
  });
  if (copy) return false;
  while (!robot.keyframes.empty() &&
         (robot.keyframes.size() >= max_per_robot_ || robot.bytes + bytes > max_bytes_per_robot_)) {
    robot.bytes -= bytesOf(robot.keyframes.front());
    robot.keyframes.pop_front();
    ++dropped_;
  }
  robot.bytes += bytes;
  robot.keyframes.push_back(std::move(kf));
  return true;
}

std::vector<msg::Keyframe> HelloHold::release(const std::string& robot_id) {
  std::vector<msg::Keyframe> out;
  const auto it = robots_.find(robot_id);
  if (it == robots_.end()) return out;
  out.assign(std::make_move_iterator(it->second.keyframes.begin()),
             std::make_move_iterator(it->second.keyframes.end()));
  robots_.erase(it);
  return out;
}

size_t HelloHold::held() const {
  size_t n = 0;
  for (const auto& kv : robots_) n += kv.second.keyframes.size();
  return n;
}

}  // namespace rgbdmap
