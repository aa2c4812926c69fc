// ReliableSender: bounded retransmission queue driven by one worker waiting on a condition variable.
#include <algorithm>
#include <cmath>
#include <vector>

#include "rgbdmap/transport/reliable.hpp"

namespace rgbdmap::transport {

ReliableSender::ReliableSender(ReliableSenderOptions options, SendFn send)
    : options_(options), send_(std::move(send)), rng_(options.seed) {}

ReliableSender::~ReliableSender() { stop(); }

std::chrono::nanoseconds ReliableSender::backoff(const ReliableSenderOptions& options, int attempt,
                                                 double u) {
  const double initial = std::chrono::duration<double>(options.initial_backoff).count();
  const double cap = std::chrono::duration<double>(options.max_backoff).count();
  const double grown = initial * std::pow(options.backoff_factor, std::max(0, attempt - 1));
  const double seconds = std::min(grown, cap) * (1.0 + options.jitter * std::clamp(u, -1.0, 1.0));
  return std::chrono::nanoseconds(static_cast<int64_t>(std::max(0.0, seconds) * 1e9));
}

ReliableSender::Clock::time_point ReliableSender::nextDeadline(int attempts, Clock::time_point now) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  return now + std::chrono::duration_cast<Clock::duration>(backoff(options_, attempts, unit(rng_)));
}

void ReliableSender::schedule(uint64_t id, Item& item, Clock::time_point now) {
  item.deadline = nextDeadline(item.attempts, now);
  deadlines_.emplace(item.deadline, id);
}

void ReliableSender::start() {
  std::lock_guard<std::mutex> life(lifecycle_);
  std::lock_guard<std::mutex> lock(mutex_);
  if (worker_.joinable()) return;
  stopping_ = false;
  worker_ = std::thread([this] { run(); });
}

void ReliableSender::stop() {
  std::lock_guard<std::mutex> life(lifecycle_);  // held across the join: concurrent stop() calls are safe
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!worker_.joinable()) return;
    stopping_ = true;
  }
  wake_.notify_all();
  worker_.join();
}

Status ReliableSender::submit(uint64_t id) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (items_.count(id) != 0) return Status::failure("id already pending");
    if (items_.size() >= options_.max_pending) {
      ++stats_.dropped_when_full;
      return Status::failure("reliable send queue full");
    }
    Item item;
    item.attempts = 1;
    schedule(id, item, Clock::now());
    const bool earliest = deadlines_.begin()->second == id;
    items_.emplace(id, item);
    ++stats_.submitted;
    if (earliest) wake_.notify_all();
  }
  if (!send_(id)) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.send_failures;  // the retransmission schedule covers it
  }
  return Status::success();
}

bool ReliableSender::acknowledge(uint64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = items_.find(id);
  if (it == items_.end()) return false;
  deadlines_.erase({it->second.deadline, id});
  items_.erase(it);
  ++stats_.acked;
  changed_.notify_all();
  return true;
}

size_t ReliableSender::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return items_.size();
}

ReliableSenderStats ReliableSender::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

bool ReliableSender::waitForCapacity(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, timeout, [this] { return items_.size() < options_.max_pending; });
}

bool ReliableSender::waitUntilEmpty(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, timeout, [this] { return items_.empty(); });
}

void ReliableSender::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  std::vector<uint64_t> due;
  while (!stopping_) {
    if (deadlines_.empty()) {
      wake_.wait(lock, [this] { return stopping_ || !deadlines_.empty(); });
      continue;
    }
    const auto now = Clock::now();
    const Clock::time_point earliest = deadlines_.begin()->first;  // a copy: the set may change while waiting
    if (now < earliest) {
      wake_.wait_until(lock, earliest);
      continue;
    }
    due.clear();
    while (!deadlines_.empty() && deadlines_.begin()->first <= now) {
      const uint64_t id = deadlines_.begin()->second;
      deadlines_.erase(deadlines_.begin());
      Item& item = items_.at(id);
      if (item.attempts >= options_.max_attempts) {
        items_.erase(id);
        ++stats_.given_up;
        changed_.notify_all();
        continue;
      }
      ++item.attempts;
      ++stats_.retransmissions;
      schedule(id, item, now);
      due.push_back(id);
    }
    lock.unlock();
    uint64_t failures = 0;
    for (const uint64_t id : due) failures += send_(id).ok() ? 0 : 1;
    lock.lock();
    stats_.send_failures += failures;
  }
}

}  // namespace rgbdmap::transport
