#include "rgbdmap/backend/global_bundle_schedule.hpp"

#include <algorithm>

namespace rgbdmap {

void GlobalBundleSchedule::keyframeAdded(int map) {
  ++added_[map];
  changed_.insert(map);
}

std::set<int> GlobalBundleSchedule::dueAfterBatch(bool asked, bool large_change,
                                                  const KeyframeCount& keyframes) const {
  std::set<int> maps;
  for (const auto& [map, added] : added_)
    if (config_.every_keyframes > 0 && added >= config_.every_keyframes && grownEnough(map, keyframes(map)))
      maps.insert(map);
  if (asked) maps.insert(changed_.begin(), changed_.end());
  if (large_change)
    for (int map : changed_)
      if (grownEnough(map, keyframes(map))) maps.insert(map);
  return maps;
}

bool GlobalBundleSchedule::grownEnough(int map, size_t keyframes) const {
  if (!(config_.min_growth_fraction > 0.0)) return true;
  const auto it = added_.find(map);
  const int added = it == added_.end() ? 0 : it->second;
  return added >= config_.min_growth_fraction * backoff(map) * static_cast<double>(keyframes);
}

bool GlobalBundleSchedule::overLimit(size_t keyframes) const {
  return config_.max_keyframes > 0 && keyframes > static_cast<size_t>(config_.max_keyframes);
}

void GlobalBundleSchedule::started(int map) {
  added_[map] = 0;
  changed_.erase(map);
}

GlobalBundleSchedule::Verdict GlobalBundleSchedule::finished(int map, const GlobalRunOutcome& outcome) {
  int& factor = backoff_[map];
  const bool fruitless = outcome.unfinished && !(outcome.final_rms_px < 0.99 * outcome.initial_rms_px);
  factor = fruitless ? std::min(64, std::max(1, factor) * 2) : 1;
  return {fruitless, factor};
}

int GlobalBundleSchedule::backoff(int map) const {
  const auto it = backoff_.find(map);
  return it == backoff_.end() ? 1 : std::max(1, it->second);
}

}  // namespace rgbdmap
