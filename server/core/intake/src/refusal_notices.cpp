#include "rgbdmap/intake/refusal_notices.hpp"

#include <algorithm>

namespace rgbdmap {

RefusalNotices::RefusalNotices(RefusalNoticeOptions options)
    : options_(options), tokens_(options.per_second) {}

bool RefusalNotices::makeRoom(Clock::time_point now) {
  const auto forget = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.forget_after_s));
  for (auto it = ids_.begin(); it != ids_.end();)
    it = it->second.noticed && now - it->second.last_notice > forget ? ids_.erase(it) : std::next(it);
  return ids_.size() < options_.max_ids;
}

std::optional<msg::ServerStatus> RefusalNotices::refused(const std::string& robot, const std::string& reason,
                                                         Clock::time_point now) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = ids_.find(robot);
  if (it == ids_.end()) {
    if (ids_.size() >= options_.max_ids && !makeRoom(now)) return std::nullopt;
    it = ids_.emplace(robot, Entry{}).first;
  }
  Entry& e = it->second;
  ++e.refused;
  if (e.noticed && std::chrono::duration<double>(now - e.last_notice).count() < options_.min_interval_s)
    return std::nullopt;
  if (refilled_ != Clock::time_point{})
    tokens_ = std::min(options_.per_second,
                       tokens_ + options_.per_second * std::chrono::duration<double>(now - refilled_).count());
  refilled_ = now;
  if (tokens_ < 1.0) return std::nullopt;
  tokens_ -= 1.0;
  e.noticed = true;
  e.last_notice = now;
  ++sent_;
  msg::ServerStatus notice;
  notice.state = "not serving " + robot;
  notice.rejects.push_back(msg::RejectCount{robot, reason, e.refused});
  return notice;
}

uint64_t RefusalNotices::sent() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sent_;
}

}  // namespace rgbdmap
