#include "rgbdmap/intake/keyframe_throttle.hpp"

#include <algorithm>

namespace rgbdmap {

bool KeyframeThrottle::allow(const std::string& robot, Clock::time_point now) {
  if (!enabled()) return true;
  std::lock_guard<std::mutex> lock(mutex_);
  auto [it, added] = buckets_.try_emplace(robot);
  Bucket& b = it->second;
  if (added) {
    b.tokens = burst_;
  } else if (now > b.last) {
    b.tokens = std::min(burst_, b.tokens + std::chrono::duration<double>(now - b.last).count() * rate_per_s_);
  }
  b.last = std::max(b.last, now);
  if (b.tokens < 1.0) return false;
  b.tokens -= 1.0;
  return true;
}

}  // namespace rgbdmap
