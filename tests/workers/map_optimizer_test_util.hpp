#pragma once
// The map optimiser tests' result collector (waits for a revision) and weighted pose-graph edges.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>

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

inline PoseGraphEdge edge(int64_t id, int64_t from, int64_t to, const SE3& T_from_to, EdgeKind kind,
                          double sigma_t, double sigma_r) {
  PoseGraphEdge e;
  e.id = id;
  e.from = from;
  e.to = to;
  e.T_from_to = T_from_to;
  e.kind = kind;
  e.information.setZero();
  e.information.diagonal() << Vec3::Constant(1.0 / (sigma_t * sigma_t)),
      Vec3::Constant(1.0 / (sigma_r * sigma_r));
  return e;
}

}  // namespace rgbdmap::testing
