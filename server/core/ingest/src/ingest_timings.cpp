#include "rgbdmap/ingest/ingest_timings.hpp"

namespace rgbdmap {

void IngestTimings::add(const KeyframeTiming& t) {
  decode_ms_.add(t.decode_ms);
  if (t.decode_thread_cpu_ms > 0.0) decode_cpu_ms_.add(t.decode_thread_cpu_ms);
  store_ms_.add(t.store_ms);
  loops_ms_.add(t.loops_ms);
  ingest_ms_.add(t.total_ms);
  ingest_cpu_ms_.add(t.cpu_ms);
}

void IngestTimings::fill(IngestStats* s) const {
  s->ingest_ms_median = ingest_ms_.median();
  s->ingest_ms_p90 = ingest_ms_.quantile(0.9);
  s->ingest_ms_max = ingest_ms_.max();
  s->ingest_cpu_ms_median = ingest_cpu_ms_.median();
  s->ingest_cpu_ms_p90 = ingest_cpu_ms_.quantile(0.9);
  s->verify_ms_median = verify_ms_.median();
  s->decode_ms_median = decode_ms_.median();
  s->decode_cpu_ms_median = decode_cpu_ms_.median();
  s->store_ms_median = store_ms_.median();
  s->loops_ms_median = loops_ms_.median();
}

}  // namespace rgbdmap
