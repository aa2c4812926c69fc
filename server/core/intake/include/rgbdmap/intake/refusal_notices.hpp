#pragma once
// The server's answer to a robot it does not serve. When messages claiming to come from robot id R are
// refused because R is not served (the server holds no key for R: "unknown_sender"; R is not in
// server.robots: "unknown_robot"), R's status channel gets a ServerStatus saying so: state "not serving R",
// no robots, and one RejectCount {R, reason, messages refused so far}. The server holds no key it shares
// with R, so the notice goes unsigned and R cannot verify it: R only words its diagnosis with it, never acts
// on it (a forged notice cannot stop a robot or drop a keyframe). Rate-limited per claimed id
// (min_interval_s) and overall (per_second, burst of the same size), over at most max_ids claimed ids (an
// id not noticed for forget_after_s makes room), so invented ids can neither make the server flood the
// network nor grow its memory. Thread-safe.
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct RefusalNoticeOptions {
  double min_interval_s = 1.0;  ///< per claimed id
  double per_second = 8.0;      ///< over all claimed ids
  size_t max_ids = 256;
  double forget_after_s = 60.0;
};

class RefusalNotices {
 public:
  using Clock = std::chrono::steady_clock;
  explicit RefusalNotices(RefusalNoticeOptions options = {});

  /// Counts one refused message from `robot` (the channel's robot id, valid by then) and returns the notice
  /// to send to it now, if one is due.
  std::optional<msg::ServerStatus> refused(const std::string& robot, const std::string& reason,
                                           Clock::time_point now = Clock::now());
  uint64_t sent() const;  ///< notices returned so far

 private:
  struct Entry {
    int64_t refused = 0;
    Clock::time_point last_notice{};
    bool noticed = false;
  };
  bool makeRoom(Clock::time_point now);  ///< caller holds mutex_

  const RefusalNoticeOptions options_;
  mutable std::mutex mutex_;
  std::map<std::string, Entry> ids_;
  double tokens_;
  Clock::time_point refilled_{};
  uint64_t sent_ = 0;
};

}  // namespace rgbdmap
