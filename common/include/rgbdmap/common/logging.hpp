#pragma once
// The one logger. Libraries log through it (never std::cout); apps choose the level and sink.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <sstream>
#include <string>

namespace rgbdmap::log {

enum class Level { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3, kOff = 4 };

void setLevel(Level level);
Level level();
/// Parses "debug|info|warn|error|off"; returns false on an unknown name.
bool parseLevel(const std::string& name, Level* out);

/// Replace the sink (default: stderr with a timestamp). Used by tests to capture output.
using Sink = std::function<void(Level, const std::string&)>;
void setSink(Sink sink);

void write(Level level, const std::string& message);

/// Allows at most `per_second` messages per second; counts what it suppresses so the next
/// message that passes can say how many were dropped. Thread-safe.
class RateLimiter {
 public:
  explicit RateLimiter(double per_second = 1.0);
  /// True if a message may be written now; *suppressed receives the count dropped since the last one.
  bool allow(uint64_t* suppressed);

 private:
  std::atomic<int64_t> next_allowed_ns_{0};
  std::atomic<uint64_t> suppressed_{0};
  int64_t interval_ns_;
};

namespace detail {
template <typename... Args>
std::string concat(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}
}  // namespace detail

template <typename... Args>
void debug(const Args&... args) {
  if (level() <= Level::kDebug) write(Level::kDebug, detail::concat(args...));
}
template <typename... Args>
void info(const Args&... args) {
  if (level() <= Level::kInfo) write(Level::kInfo, detail::concat(args...));
}
template <typename... Args>
void warn(const Args&... args) {
  if (level() <= Level::kWarn) write(Level::kWarn, detail::concat(args...));
}
template <typename... Args>
void error(const Args&... args) {
  if (level() <= Level::kError) write(Level::kError, detail::concat(args...));
}

}  // namespace rgbdmap::log
