#include "rgbdmap/workers/memory_trim.hpp"

#include <malloc.h>
#include <unistd.h>

#include <cstdio>

#include "rgbdmap/workers/thread_time.hpp"

namespace rgbdmap {
namespace {

/// Resident bytes of this process (/proc/self/statm), 0 when unreadable.
int64_t residentBytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  long long pages = 0, resident = 0;
  const int n = std::fscanf(f, "%lld %lld", &pages, &resident);
  std::fclose(f);
  return n == 2 ? resident * static_cast<int64_t>(sysconf(_SC_PAGESIZE)) : 0;
}

}  // namespace

MemoryTrim::MemoryTrim(double period_s)
    : worker_(SerialWorkerOptions{"rgbdmap-trim", 0, period_s, [this] { tick(); }}) {}

void MemoryTrim::start() { worker_.start(); }

void MemoryTrim::stop() { worker_.stop(); }

int64_t MemoryTrim::trimNow() {
  const int64_t before = residentBytes();
  malloc_trim(0);
  // Other threads allocating meanwhile make this an underestimate, never an overestimate.
  const int64_t released = before - residentBytes();
  return released > 0 ? released : 0;
}

void MemoryTrim::tick() {
  const double cpu0 = threadCpuMs();
  released_ += trimNow();
  cpu_us_ += static_cast<int64_t>((threadCpuMs() - cpu0) * 1000.0);
  ++trims_;
}

MemoryTrimStats MemoryTrim::stats() const {
  MemoryTrimStats s;
  s.trims = trims_.load();
  s.released_bytes = released_.load();
  s.cpu_ms = static_cast<double>(cpu_us_.load()) / 1000.0;
  return s;
}

}  // namespace rgbdmap
