#pragma once
// The map optimiser tests' result collector (waits for a revision) and weighted pose-graph edges.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>

#include "backend/backend_test_util.hpp"
#include "rgbdmap/workers/map_optimizer.hpp"

namespace rgbdmap::testing {

struct Collector {
  std::mutex mutex;
  std::condition_variable cv;
  std::shared_ptr<const MapOptimization> latest;

  void operator()(const std::shared_ptr<const MapOptimization>& r) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      latest = r;
    }
    cv.notify_all();
  }
  std::shared_ptr<const MapOptimization> waitFor(uint64_t revision) {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait_for(lock, std::chrono::seconds(60), [&] { return latest && latest->revision >= revision; });
    return latest;
  }
};

}  // namespace rgbdmap::testing
