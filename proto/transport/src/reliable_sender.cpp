// ReliableSender: bounded retransmission queue driven by one worker waiting on a condition variable.
#include <algorithm>
#include <cstdlib>
#include <vector>

#include "rgbdmap/transport/reliable.hpp"

namespace rgbdmap::transport {

namespace {

using std::chrono::nanoseconds;

nanoseconds scaled(nanoseconds d, double factor) {
  return nanoseconds(static_cast<int64_t>(std::max(0.0, static_cast<double>(d.count()) * factor)));
}

double toMs(nanoseconds d) { return std::chrono::duration<double, std::milli>(d).count(); }

}  // namespace

ReliableSender::ReliableSender(ReliableSenderOptions options, SendFn send, GiveUpFn given_up)
    : options_(options),
      send_(std::move(send)),
      given_up_(std::move(given_up)),
      rng_(options.seed),
      rto_(rto(options_, rtt_)) {}

ReliableSender::~ReliableSender() { stop(); }

RttEstimate ReliableSender::updateRtt(const RttEstimate& estimate, nanoseconds sample) {
  RttEstimate out;
  out.samples = estimate.samples + 1;
  if (estimate.samples == 0) {  // 2.2
    out.srtt = sample;
    out.rttvar = sample / 2;
    return out;
  }
  // 2.3, RTTVAR first (it uses the previous SRTT)
  out.rttvar = (3 * estimate.rttvar + nanoseconds(std::abs((estimate.srtt - sample).count()))) / 4;
  out.srtt = (7 * estimate.srtt + sample) / 8;
  return out;
}

nanoseconds ReliableSender::rto(const ReliableSenderOptions& options, const RttEstimate& estimate) {
  if (estimate.samples == 0) return std::min<nanoseconds>(options.initial_backoff, options.max_backoff);
  const nanoseconds value = estimate.srtt + std::max<nanoseconds>(kGranularity, 4 * estimate.rttvar);
  return std::min<nanoseconds>(std::max<nanoseconds>(value, options.min_backoff), options.max_backoff);
}

nanoseconds ReliableSender::backedOff(const ReliableSenderOptions& options, nanoseconds previous,
                                      nanoseconds rto_now) {
  return std::min<nanoseconds>(std::max(scaled(previous, options.backoff_factor), rto_now),
                               options.max_backoff);
}

nanoseconds ReliableSender::jittered(const ReliableSenderOptions& options, nanoseconds delay, double u) {
  return scaled(delay, 1.0 + options.jitter * std::clamp(u, -1.0, 1.0));
}

void ReliableSender::schedule(uint64_t id, Item& item, Clock::time_point now) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  // Adaptive: the RTO already is the earliest moment a retransmission is justified, so jitter only delays.
  const double u = options_.adaptive ? std::abs(unit(rng_)) : unit(rng_);
  item.deadline = now + std::chrono::duration_cast<Clock::duration>(jittered(options_, item.delay, u));
  deadlines_.emplace(item.deadline, id);
}

void ReliableSender::noteSample(nanoseconds sample) {
  rtt_ = updateRtt(rtt_, sample);
  if (options_.adaptive) rto_ = rto(options_, rtt_);  // a valid sample ends a backoff (RFC 6298 5.7)
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
    item.attempts = item.unanswered = 1;
    item.first_sent = Clock::now();
    item.delay = rto_;
    schedule(id, item, item.first_sent);
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
  // Karn's rule: the ack of a retransmitted id may answer any of its sends, so only single sends count.
  if (it->second.attempts == 1) noteSample(Clock::now() - it->second.first_sent);
  deadlines_.erase({it->second.deadline, id});
  items_.erase(it);
  ++stats_.acked;
  changed_.notify_all();
  return true;
}

void ReliableSender::progress(uint64_t id, nanoseconds round_trip) {
  std::lock_guard<std::mutex> lock(mutex_);
  noteSample(round_trip);
  auto it = items_.find(id);
  if (it == items_.end()) return;
  deadlines_.erase({it->second.deadline, id});
  it->second.delay = rto_;
  it->second.unanswered = 0;
  schedule(id, it->second, Clock::now());
  if (deadlines_.begin()->second == id) wake_.notify_all();
}

void ReliableSender::resendAllNow() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (items_.empty()) return;
  const auto now = Clock::now();
  deadlines_.clear();
  for (auto& [id, item] : items_) {
    item.delay = rto_;  // the worker backs it off once as it sends
    item.unanswered = 0;
    item.deadline = now;
    deadlines_.emplace(now, id);
  }
  wake_.notify_all();
}

size_t ReliableSender::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return items_.size();
}

ReliableSenderStats ReliableSender::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  ReliableSenderStats out = stats_;
  out.rtt_samples = rtt_.samples;
  out.srtt_ms = toMs(rtt_.srtt);
  out.rttvar_ms = toMs(rtt_.rttvar);
  out.rto_ms = toMs(rto_);
  return out;
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
  std::vector<uint64_t> due, dropped;
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
    dropped.clear();
    while (!deadlines_.empty() && deadlines_.begin()->first <= now) {
      const uint64_t id = deadlines_.begin()->second;
      deadlines_.erase(deadlines_.begin());
      Item& item = items_.at(id);
      if (options_.max_attempts > 0 && item.unanswered >= options_.max_attempts) {
        items_.erase(id);
        ++stats_.given_up;
        changed_.notify_all();
        dropped.push_back(id);
        continue;
      }
      ++item.attempts;
      ++item.unanswered;
      ++stats_.retransmissions;
      item.delay = backedOff(options_, item.delay, rto_);
      if (options_.adaptive && options_.shared_backoff)
        rto_ = std::max(rto_, item.delay);  // kept for new ids (RFC 6298 5.5)
      schedule(id, item, now);
      due.push_back(id);
    }
    lock.unlock();
    uint64_t failures = 0;
    for (const uint64_t id : due) failures += send_(id).ok() ? 0 : 1;
    if (given_up_)
      for (const uint64_t id : dropped) given_up_(id);
    lock.lock();
    stats_.send_failures += failures;
  }
}

}  // namespace rgbdmap::transport
