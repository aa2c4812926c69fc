#include "rgbdmap/transport/republisher.hpp"

namespace rgbdmap::transport {

LatestRepublisher::LatestRepublisher(Transport& transport, RepublisherOptions options)
    : transport_(transport), options_(std::move(options)) {}

LatestRepublisher::~LatestRepublisher() { stop(); }

Status LatestRepublisher::publish(const std::string& channel, const std::vector<uint8_t>& bytes) {
  if (isLatestForLateJoiners(channel, options_.channels)) {
    std::lock_guard<std::mutex> lock(mutex_);
    latest_[channel] = bytes;
  }
  return transport_.publish(channel, bytes);
}

void LatestRepublisher::start() {
  std::lock_guard<std::mutex> life(lifecycle_);
  std::lock_guard<std::mutex> lock(mutex_);
  if (running_) return;
  running_ = true;
  worker_ = std::thread(&LatestRepublisher::run, this);
}

void LatestRepublisher::stop() {
  std::lock_guard<std::mutex> life(lifecycle_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!running_) return;
    running_ = false;
  }
  wake_.notify_all();
  worker_.join();
}

uint64_t LatestRepublisher::republished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return republished_;
}

void LatestRepublisher::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  auto next = std::chrono::steady_clock::now() + options_.period;
  while (running_) {
    if (wake_.wait_until(lock, next, [this] { return !running_; })) break;
    next += options_.period;
    const auto snapshot = latest_;  // publish without holding the lock
    lock.unlock();
    for (const auto& [channel, bytes] : snapshot) {
      if (!options_.refresh) {
        transport_.publish(channel, bytes);
        continue;
      }
      std::vector<uint8_t> fresh = options_.refresh(channel, bytes);
      if (!fresh.empty()) transport_.publish(channel, fresh);
    }
    lock.lock();
    republished_ += snapshot.size();
  }
}

}  // namespace rgbdmap::transport
