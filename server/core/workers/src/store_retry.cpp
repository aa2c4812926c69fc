#include "rgbdmap/workers/store_retry.hpp"

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

StoreRetry::StoreRetry(double retry_s, MapStore& store)
    : store_(store), worker_(SerialWorkerOptions{"rgbdmap-store", 0, retry_s, [this] { tick(); }}) {}

void StoreRetry::start() { worker_.start(); }

void StoreRetry::stop() { worker_.stop(); }

void StoreRetry::tick() {
  if (!store_.health().failed) return;
  if (const Status s = store_.recover(); !s) {
    ++failed_attempts_;
    bool power_of_ten = true;  // 1, 10, 100, ...: a full disk that stays full does not flood the log
    for (uint64_t n = failed_attempts_; n > 1 && power_of_ten; n /= 10) power_of_ten = n % 10 == 0;
    if (power_of_ten)
      log::warn("server: map store still failed after ", failed_attempts_,
                " attempt(s) to recover: ", s.error());
    return;
  }
  log::info("server: map store recovered after ", failed_attempts_ + 1,
            " attempt(s); keyframes are stored and acknowledged again");
  failed_attempts_ = 0;
}

}  // namespace rgbdmap
