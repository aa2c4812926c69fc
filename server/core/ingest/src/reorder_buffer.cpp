#include "rgbdmap/ingest/reorder_buffer.hpp"

#include <utility>

namespace rgbdmap {

void ReorderBuffer::add(const KeyframeKey& key, const KeyframeKey& predecessor, WaitingKeyframe waiting) {
  if (!by_key_.emplace(key, Entry{predecessor, std::move(waiting)}).second) return;
  by_predecessor_.emplace(predecessor, key);
}

WaitingKeyframe ReorderBuffer::take(const KeyframeKey& key) {
  const auto it = by_key_.find(key);
  const auto [first, last] = by_predecessor_.equal_range(it->second.predecessor);
  for (auto p = first; p != last; ++p) {
    if (p->second != key) continue;
    by_predecessor_.erase(p);
    break;
  }
  WaitingKeyframe out = std::move(it->second.waiting);
  by_key_.erase(it);
  return out;
}

std::vector<WaitingKeyframe> ReorderBuffer::takeSuccessors(const KeyframeKey& predecessor) {
  std::vector<KeyframeKey> keys;
  const auto [first, last] = by_predecessor_.equal_range(predecessor);
  for (auto p = first; p != last; ++p) keys.push_back(p->second);
  std::vector<WaitingKeyframe> out;
  for (const KeyframeKey& key : keys) out.push_back(take(key));
  return out;
}

KeyframeKey ReorderBuffer::headOf(const KeyframeKey& key) const {
  KeyframeKey head = key;
  for (size_t steps = 0; steps < by_key_.size(); ++steps) {  // bounded: a forged cycle ends somewhere
    const auto it = by_key_.find(by_key_.at(head).predecessor);
    if (it == by_key_.end()) break;
    head = it->first;
  }
  return head;
}

std::optional<KeyframeKey> ReorderBuffer::oldest(std::optional<int> robot) const {
  std::optional<KeyframeKey> best;
  Clock::time_point best_since = Clock::time_point::max();
  for (const auto& [key, entry] : by_key_) {
    if (robot && std::get<0>(key) != *robot) continue;
    if (entry.waiting.since >= best_since) continue;
    best_since = entry.waiting.since;
    best = key;
  }
  return best;
}

std::optional<WaitingKeyframe> ReorderBuffer::takeRunToGiveUp(Clock::time_point now, double timeout_s,
                                                              size_t capacity) {
  std::map<int, size_t> per_robot;
  for (const auto& [key, entry] : by_key_) ++per_robot[std::get<0>(key)];
  for (const auto& [robot, count] : per_robot)
    if (count > capacity) return take(headOf(*oldest(robot)));
  const std::optional<KeyframeKey> first = oldest(std::nullopt);
  if (!first) return std::nullopt;
  const auto timeout = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  if (by_key_.at(*first).waiting.since + timeout > now) return std::nullopt;
  return take(headOf(*first));
}

size_t ReorderBuffer::waiting(int robot) const {
  size_t n = 0;
  for (const auto& [key, entry] : by_key_) n += std::get<0>(key) == robot;
  return n;
}

}  // namespace rgbdmap
