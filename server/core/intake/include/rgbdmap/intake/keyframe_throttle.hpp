#pragma once
// Per-robot keyframe rate limit ("fair share"): a token bucket per robot, refilled at
// `rate_per_s` up to `burst` tokens; each keyframe message (first transmissions and retransmissions alike)
// takes one. The inbox asks before decoding the keyframe's payload: a keyframe over the rate is dropped
// unacknowledged (the robot resends it) and counted per robot, and costs the server nothing but the
// signature check. Thread-safe (one mutex); the clock is a parameter, so tests need no sleeps.
#include <chrono>
#include <map>
#include <mutex>
#include <string>

namespace rgbdmap {

class KeyframeThrottle {
 public:
  using Clock = std::chrono::steady_clock;

  /// rate_per_s <= 0 turns the limit off. A robot's bucket starts full.
  KeyframeThrottle(double rate_per_s, double burst) : rate_per_s_(rate_per_s), burst_(burst) {}

  /// Takes a token of `robot`'s bucket at `now`; false when it is empty (the keyframe is over the rate).
  bool allow(const std::string& robot, Clock::time_point now);
  bool enabled() const { return rate_per_s_ > 0.0; }

 private:
  struct Bucket {
    double tokens = 0.0;
    Clock::time_point last;
  };
  const double rate_per_s_;
  const double burst_;
  std::mutex mutex_;
  std::map<std::string, Bucket> buckets_;  ///< robots the key store admits (bounded by it)
};

}  // namespace rgbdmap
