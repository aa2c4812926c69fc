#include "rgbdmap/vision/feature_cache.hpp"

#include <utility>

namespace rgbdmap {

FeatureCache::FeatureCache(size_t max_resident, Loader loader)
    : max_resident_(max_resident), loader_(std::move(loader)) {}

void FeatureCache::touchLocked(int64_t, Entry& e) { lru_.splice(lru_.begin(), lru_, e.lru); }

void FeatureCache::makeResidentLocked(int64_t id, Entry& e, std::shared_ptr<const FrameFeatures> features) {
  e.weak = features;
  e.strong = std::move(features);
  lru_.push_front(id);
  e.lru = lru_.begin();
  while (max_resident_ > 0 && lru_.size() > max_resident_) {
    Entry& old = entries_.at(lru_.back());
    old.strong.reset();  // `weak` still finds them while a caller holds them
    lru_.pop_back();
    ++stats_.evictions;
  }
}

void FeatureCache::add(int64_t id, std::shared_ptr<const FrameFeatures> features) {
  if (!features) return;
  std::lock_guard<std::mutex> lock(mutex_);
  auto [it, inserted] = entries_.try_emplace(id);
  Entry& e = it->second;
  if (!inserted && e.strong) lru_.erase(e.lru);
  e.size = features->size();
  makeResidentLocked(id, e, std::move(features));
}

std::shared_ptr<const FrameFeatures> FeatureCache::get(int64_t id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(id);
    if (it == entries_.end()) return nullptr;
    Entry& e = it->second;
    if (e.strong) {
      touchLocked(id, e);
      return e.strong;
    }
    if (auto alive = e.weak.lock()) {  // dropped by the cache, still held by a caller: the same object
      makeResidentLocked(id, e, alive);
      return alive;
    }
  }
  // Read back without the lock (disk I/O); two threads may both load one id: the first to finish wins.
  Result<FrameFeatures> loaded = loader_ ? loader_(id) : Result<FrameFeatures>::failure("no loader");
  std::lock_guard<std::mutex> lock(mutex_);
  Entry& e = entries_.at(id);
  if (e.strong) {
    touchLocked(id, e);
    return e.strong;
  }
  if (!loaded || loaded->size() != e.size) {
    ++stats_.load_failures;
    return nullptr;
  }
  ++stats_.loads;
  auto features = std::make_shared<const FrameFeatures>(std::move(loaded).value());
  makeResidentLocked(id, e, features);
  return features;
}

bool FeatureCache::contains(int64_t id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.count(id) != 0;
}

FeatureCacheStats FeatureCache::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  FeatureCacheStats s = stats_;
  s.keyframes = entries_.size();
  s.resident = lru_.size();
  return s;
}

}  // namespace rgbdmap
