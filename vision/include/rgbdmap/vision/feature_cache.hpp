#pragma once
// Keyframe features that may leave RAM (memory proportional to the working set). The server's
// loop detector and bundle adjustment hold a keyframe's features through one FeatureCache: the most
// recently used `max_resident` stay in RAM, older ones are dropped and read back through the loader (the
// server: from its map store) when a loop candidate, a BA window or a track needs them again. A caller
// holding the shared_ptr keeps the features alive whatever the cache does, and while anyone holds them a
// get() returns the same object (no second copy). Thread-safe; no I/O of its own (the loader does it).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <unordered_map>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

struct FeatureCacheStats {
  size_t keyframes = 0;        ///< known ids
  size_t resident = 0;         ///< held in RAM by the cache (others may still be alive in a caller's hands)
  uint64_t loads = 0;          ///< read back through the loader
  uint64_t load_failures = 0;  ///< the loader failed or returned features of another size (get() gave null)
  uint64_t evictions = 0;      ///< dropped from RAM (least recently used beyond max_resident)
};

class FeatureCache {
 public:
  /// Reads a keyframe's features back (e.g. from the map store); called without the cache's lock held,
  /// possibly from several threads at once.
  using Loader = std::function<Result<FrameFeatures>(int64_t id)>;
  /// max_resident 0: nothing is ever dropped (the loader is never called).
  FeatureCache(size_t max_resident, Loader loader);

  /// A new keyframe's features, resident and most recently used. Replaces what an id had before.
  void add(int64_t id, std::shared_ptr<const FrameFeatures> features);
  /// The features of `id`: from RAM, or read back through the loader (then resident again, most recently
  /// used). Null for an unknown id or when the loader fails (counted in load_failures).
  std::shared_ptr<const FrameFeatures> get(int64_t id);
  bool contains(int64_t id) const;
  FeatureCacheStats stats() const;

 private:
  struct Entry {
    std::shared_ptr<const FrameFeatures> strong;  ///< null when dropped
    std::weak_ptr<const FrameFeatures> weak;      ///< alive while anyone holds them
    std::list<int64_t>::iterator lru;             ///< valid when strong
    size_t size = 0;                              ///< feature count, to check what the loader returns
  };
  void touchLocked(int64_t id, Entry& e);
  void makeResidentLocked(int64_t id, Entry& e, std::shared_ptr<const FrameFeatures> features);

  const size_t max_resident_;
  const Loader loader_;
  mutable std::mutex mutex_;
  std::unordered_map<int64_t, Entry> entries_;
  std::list<int64_t> lru_;  ///< resident ids, most recently used first
  FeatureCacheStats stats_;
};

}  // namespace rgbdmap
