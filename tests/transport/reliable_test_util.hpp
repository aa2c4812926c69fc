#pragma once
// The send log of the ReliableSender tests: every send() call with its time, and durations in milliseconds.
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <vector>

#include "rgbdmap/transport/reliable.hpp"

namespace rgbdmap::transport::testing {

using Clock = std::chrono::steady_clock;

inline double ms(std::chrono::nanoseconds d) { return std::chrono::duration<double, std::milli>(d).count(); }

/// Records every send() call with its time.
struct SendLog {
  std::mutex mutex;
  std::map<uint64_t, std::vector<Clock::time_point>> sends;
  ReliableSender::SendFn fn() {
    return [this](uint64_t id) {
      std::lock_guard<std::mutex> lock(mutex);
      sends[id].push_back(Clock::now());
      return Status::success();
    };
  }
  size_t count(uint64_t id) {
    std::lock_guard<std::mutex> lock(mutex);
    return sends[id].size();
  }
};

}  // namespace rgbdmap::transport::testing
