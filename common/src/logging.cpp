#include "rgbdmap/common/logging.hpp"

#include <cstdio>
#include <ctime>
#include <mutex>

namespace rgbdmap::log {
namespace {
std::atomic<Level> g_level{Level::kInfo};
std::mutex g_sink_mutex;

const char* levelName(Level l) {
  switch (l) {
    case Level::kDebug:
      return "debug";
    case Level::kInfo:
      return "info";
    case Level::kWarn:
      return "warn";
    case Level::kError:
      return "error";
    default:
      return "off";
  }
}

void stderrSink(Level l, const std::string& msg) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t secs = std::chrono::system_clock::to_time_t(now);
  const auto ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%H:%M:%S", &tm);
  std::fprintf(stderr, "[%s.%03d %s] %s\n", stamp, static_cast<int>(ms), levelName(l), msg.c_str());
}

Sink& sink() {
  static Sink s = stderrSink;
  return s;
}
}  // namespace

void setLevel(Level l) { g_level.store(l); }
Level level() { return g_level.load(); }

bool parseLevel(const std::string& name, Level* out) {
  for (Level l : {Level::kDebug, Level::kInfo, Level::kWarn, Level::kError, Level::kOff}) {
    if (name == levelName(l)) {
      *out = l;
      return true;
    }
  }
  return false;
}

void setSink(Sink s) {
  std::lock_guard<std::mutex> lock(g_sink_mutex);
  sink() = s ? std::move(s) : Sink(stderrSink);
}

void write(Level l, const std::string& message) {
  std::lock_guard<std::mutex> lock(g_sink_mutex);
  sink()(l, message);
}

RateLimiter::RateLimiter(double per_second)
    : interval_ns_(per_second > 0 ? static_cast<int64_t>(1e9 / per_second) : 0) {}

bool RateLimiter::allow(uint64_t* suppressed) {
  const int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::steady_clock::now().time_since_epoch())
                          .count();
  int64_t next = next_allowed_ns_.load();
  if (now >= next && next_allowed_ns_.compare_exchange_strong(next, now + interval_ns_)) {
    if (suppressed) *suppressed = suppressed_.exchange(0);
    return true;
  }
  suppressed_.fetch_add(1);
  return false;
}

}  // namespace rgbdmap::log
