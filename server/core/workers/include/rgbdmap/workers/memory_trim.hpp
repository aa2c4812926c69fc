#pragma once
// Gives freed heap memory back to the kernel. glibc keeps what a thread freed in its arena: an
// octree rebuild frees the old tree's millions of nodes, bundle adjustments and feature read-backs free
// large blocks, and the process's RSS stays at its high-water mark (measured: 8.4 GB RSS over 4.9 GB of
// live heap at 14,000 keyframes). Every period_s, malloc_trim(0) releases the free pages of every arena.
// A periodic SerialWorker ("rgbdmap-trim"). A trim walks the arenas' free lists: ~240 ms of CPU per trim
// with a 4-8 GB heap (20,000 keyframes: 317 trims, 76 s of CPU in 45 min, ~3 % of a core).
#include <atomic>
#include <cstdint>

#include "rgbdmap/common/serial_worker.hpp"

namespace rgbdmap {

struct MemoryTrimStats {
  uint64_t trims = 0;
  double cpu_ms = 0.0;         ///< spent in malloc_trim, all calls
  int64_t released_bytes = 0;  ///< RSS before minus after, summed (what the kernel got back)
};

class MemoryTrim {
 public:
  explicit MemoryTrim(double period_s);  ///< period_s > 0

  void start();
  void stop();  ///< idempotent
  MemoryTrimStats stats() const;
  /// One trim now (also what the period does); returns the RSS bytes it released.
  static int64_t trimNow();

 private:
  void tick();

  std::atomic<uint64_t> trims_{0};
  std::atomic<int64_t> released_{0};
  std::atomic<int64_t> cpu_us_{0};
  SerialWorker worker_;  ///< last member
};

}  // namespace rgbdmap
