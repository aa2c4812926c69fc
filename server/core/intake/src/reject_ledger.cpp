#include "rgbdmap/intake/reject_ledger.hpp"

#include <algorithm>
#include <utility>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap {

RejectLedger::RejectLedger(RejectLedgerOptions options, std::function<bool(const std::string&)> known)
    : options_(options), known_(std::move(known)) {}

std::string RejectLedger::sanitize(const std::string& claimed) {
  const size_t limit = static_cast<size_t>(msg::kMaxIdLength);
  std::string out;
  for (size_t i = 0; i < claimed.size() && i < limit; ++i) {
    const unsigned char c = static_cast<unsigned char>(claimed[i]);
    out += (c >= 0x20 && c < 0x7f && c != '\'') ? static_cast<char>(c) : '?';
  }
  if (claimed.size() > limit) out += "...";
  return out;
}

std::string RejectLedger::reasonKey(msg::RejectReason reason) {
  std::string key = msg::toString(reason);
  std::replace(key.begin(), key.end(), ' ', '_');
  return key;
}

std::string RejectLedger::reasonKeyOf(const std::string& error) {
  // decodeMessage's errors start with toString(reason); take the longest reason that matches.
  std::string best;
  msg::RejectReason found = msg::RejectReason::kInvalidContent;
  for (int i = 0; i < static_cast<int>(msg::RejectReason::kCount); ++i) {
    const std::string name = msg::toString(static_cast<msg::RejectReason>(i));
    if (error.rfind(name, 0) == 0 && name.size() > best.size()) {
      best = name;
      found = static_cast<msg::RejectReason>(i);
    }
  }
  return reasonKey(found);
}

std::string RejectLedger::add(const std::string& claimed, const std::string& reason,
                              const std::string& detail, Clock::time_point now) {
  const std::string id = sanitize(claimed);
  std::lock_guard<std::mutex> lock(mutex_);
  // Own counters only for a known robot, and only while fewer than max_known have them.
  std::string bucket;
  if (!claimed.empty() && msg::isRobotId(claimed)) {
    if (known_cache_.count(claimed)) {
      bucket = claimed;
    } else if (known_cache_.size() < options_.max_known && known_ && known_(claimed)) {
      known_cache_[claimed] = true;
      bucket = claimed;
    }
  }
  const int64_t total = ++counts_[{bucket, reason}];
  // Known robots always have their own entry (they are at most max_known): invented ids cannot hide them.
  const bool tracked = !bucket.empty() || log_.count(id) || log_.size() < options_.max_claimed_ids;
  LogEntry& entry = tracked ? log_[id] : other_;
  ++entry.since_line;
  const auto interval =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.log_interval_s));
  if (entry.logged && now - entry.last_line < interval) return "";
  if (bucket.empty()) {
    if (now < next_unknown_line_) return "";
    next_unknown_line_ = now + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(1.0 / options_.unknown_lines_per_s));
  }
  std::string text = reason;
  std::replace(text.begin(), text.end(), '_', ' ');
  std::string line = "server: rejected a message claiming to be from '" + id + "'" +
                     (tracked ? ""
                              : " (one of the claimed ids beyond the first " +
                                    std::to_string(options_.max_claimed_ids) + ", logged together)") +
                     ": " + text + (detail.empty() ? "" : " (" + detail + ")") + "; " +
                     std::to_string(total) + " " + reason + " from " +
                     (bucket.empty() ? "unknown robots" : bucket) + " so far";
  if (entry.since_line > 1)
    line += ", " + std::to_string(entry.since_line - 1) + " from this sender not logged since its last line";
  entry.logged = true;
  entry.last_line = now;
  entry.since_line = 0;
  log::warn(line);
  return line;
}

std::vector<msg::RejectCount> RejectLedger::counts(size_t max_entries) const {
  std::vector<msg::RejectCount> out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [key, count] : counts_) out.push_back(msg::RejectCount{key.first, key.second, count});
  }
  std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.count > b.count; });
  if (out.size() > max_entries) out.resize(max_entries);
  return out;
}

size_t RejectLedger::trackedClaimedIds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return log_.size();
}

}  // namespace rgbdmap
