#pragma once
// Per-keyframe timings of the ingest worker, in bounded memory (SampleReservoir: exact up to 4096
// keyframes, a uniform sample of the run beyond), reported as IngestStats' medians and p90s.
#include <chrono>
#include <vector>

#include "rgbdmap/common/sample_reservoir.hpp"
#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/workers/thread_time.hpp"

namespace rgbdmap {

struct KeyframeTiming {
  double total_ms = 0.0;   ///< dequeue to graph update (wall)
  double cpu_ms = 0.0;     ///< the same in worker-thread CPU time
  double decode_ms = 0.0;  ///< decode + validate images, features (on the decode thread, or this one)
  double decode_thread_cpu_ms = 0.0;  ///< the decode thread's CPU time for it (0 when decoded here)
  double store_ms = 0.0;              ///< durable append
  double loops_ms = 0.0;              ///< loop detection, graph insertion, loop edges stored
};

class IngestTimings {
 public:
  void addVerify(double ms) { verify_ms_.add(ms); }
  void add(const KeyframeTiming& t);
  void fill(IngestStats* stats) const;  ///< the ingest_*, decode, store, loops and verify fields
  std::vector<double> ingestMs() const { return ingest_ms_.samples(); }

 private:
  SampleReservoir ingest_ms_, ingest_cpu_ms_, verify_ms_, decode_ms_, decode_cpu_ms_, store_ms_, loops_ms_;
};

}  // namespace rgbdmap
