#pragma once
// The store's retry thread: while the map store is failed (an append hit an I/O error, e.g. a full disk),
// every store_retry_s it calls MapStore::recover(). Meanwhile the ingest path finds the store failed and
// leaves keyframes unacknowledged, so the robots resend them and they are stored once it recovers. A
// periodic SerialWorker ("rgbdmap-store"); each attempt is bounded (a cut, a probe write and two syncs).
#include <chrono>
#include <cstdint>

#include "rgbdmap/common/serial_worker.hpp"
#include "rgbdmap/store/map_store.hpp"

namespace rgbdmap {

class StoreRetry {
 public:
  /// `store` must outlive this object; retry_s > 0.
  StoreRetry(double retry_s, MapStore& store);

  void start();
  void stop();  ///< idempotent

 private:
  void tick();

  MapStore& store_;
  uint64_t failed_attempts_ = 0;  ///< since the last recovery (logs the 1st, 10th, 100th, ... only)
  SerialWorker worker_;           ///< last member
};

}  // namespace rgbdmap
