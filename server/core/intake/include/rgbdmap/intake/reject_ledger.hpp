#pragma once
// Rejected messages per claimed sender and reason, for the status, the summary and the log. The claimed id
// is untrusted (anyone can put any id in a header or a channel name): it is sanitised before it is logged,
// and only robots the server knows (the `known` predicate: a key, the robot list, a Hello) get their own
// counters; every other claimed id is counted in the "unknown" bucket (robot_id ""). For the log, the known
// robots and at most max_claimed_ids other claimed ids are tracked (the rest share one "other" entry), each
// named at most once per log_interval_s with the number of rejections since its last line; lines about
// claimed ids that are not known robots are also limited to unknown_lines_per_s overall. Thread-safe.
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {

struct RejectLedgerOptions {
  size_t max_claimed_ids = 256;  ///< distinct claimed ids named in the log; the rest are "other"
  size_t max_known = static_cast<size_t>(msg::kMaxRobots);  ///< known robots with their own counters
  double log_interval_s = 10.0;                             ///< per claimed id
  /// Over all claimed ids that are not known robots (a flood of invented ids cannot flood the log); their
  /// counts wait for a later line.
  double unknown_lines_per_s = 1.0;
};

class RejectLedger {
 public:
  using Clock = std::chrono::steady_clock;
  RejectLedger(RejectLedgerOptions options, std::function<bool(const std::string&)> known);

  /// Counts one rejection of a message claiming to come from `claimed` (raw, unverified) and logs it if
  /// this claimed id was not named within log_interval_s. Returns the line logged ("" when suppressed).
  std::string add(const std::string& claimed, const std::string& reason, const std::string& detail = "",
                  Clock::time_point now = Clock::now());

  /// The counters, largest first, at most `max_entries` (msg::kMaxRejectCounts for ServerStatus).
  std::vector<msg::RejectCount> counts(size_t max_entries = msg::kMaxRejectCounts) const;
  size_t trackedClaimedIds() const;  ///< entries of the log table (besides the one shared "other")

  /// Printable ASCII ('?' for anything else), at most kMaxIdLength characters ("..." appended when cut).
  static std::string sanitize(const std::string& claimed);
  /// "bad signature" -> "bad_signature" (an id-like reason for ServerStatus).
  static std::string reasonKey(msg::RejectReason reason);
  /// The reason key of a decodeMessage error ("invalid_content" when none matches).
  static std::string reasonKeyOf(const std::string& error);

 private:
  struct LogEntry {
    Clock::time_point last_line{};
    bool logged = false;
    uint64_t since_line = 0;  ///< rejections not yet reported in a line
  };

  const RejectLedgerOptions options_;
  const std::function<bool(const std::string&)> known_;
  mutable std::mutex mutex_;
  std::map<std::pair<std::string, std::string>, int64_t> counts_;  ///< (robot or "", reason) -> count
  std::map<std::string, LogEntry> log_;      ///< sanitised claimed id -> log state (max_claimed_ids + known)
  LogEntry other_;                           ///< every claimed id beyond those
  Clock::time_point next_unknown_line_{};    ///< for lines about claimed ids that are not known robots
  std::map<std::string, bool> known_cache_;  ///< robots given their own counters (at most max_known)
};

}  // namespace rgbdmap
