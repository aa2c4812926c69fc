#include "rgbdmap/viewer/client_session.hpp"

#include <utility>

namespace rgbdmap::viewer {
namespace {

/// Foxglove messageData: opcode 0x01, subscription id (uint32 LE), receive time ns (uint64 LE), payload.
std::string messageDataFrame(uint32_t subscription, uint64_t time_ns, const std::string& payload) {
  std::string out(13 + payload.size(), '\0');
  out[0] = 0x01;
  for (int i = 0; i < 4; ++i) out[1 + i] = static_cast<char>((subscription >> (8 * i)) & 0xff);
  for (int i = 0; i < 8; ++i) out[5 + i] = static_cast<char>((time_ns >> (8 * i)) & 0xff);
  out.replace(13, payload.size(), payload);
  return out;
}

}  // namespace

ClientSession::ClientSession(uint64_t id, SessionLimits limits, Writer writer, Resend resend)
    : id_(id), limits_(limits), writer_(std::move(writer)), resend_(std::move(resend)) {}

ClientSession::~ClientSession() { close(); }

void ClientSession::start() {
  thread_ = std::thread([this] { run(); });
}

void ClientSession::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
    queue_.clear();
    queued_bytes_ = 0;
  }
  wake_.notify_all();
  if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) thread_.join();
}

bool ClientSession::pushLocked(Frame frame, bool incremental) {
  if (closed_ || failed_) return false;
  const size_t size = frame.size();
  if (queue_.size() >= limits_.max_queue_messages || queued_bytes_ + size > limits_.max_queue_bytes) {
    ++counters_.dropped_messages;
    counters_.dropped_bytes += size;
    if (frame.binary) (incremental ? awaiting_snapshot_ : stale_).insert(frame.channel);
    return false;
  }
  queued_bytes_ += size;
  queue_.push_back(std::move(frame));
  wake_.notify_one();
  return true;
}

bool ClientSession::sendText(std::string text) {
  std::lock_guard<std::mutex> lock(mutex_);
  Frame f;
  f.text = std::move(text);
  return pushLocked(std::move(f), false);
}

bool ClientSession::sendMessage(uint32_t channel, const std::shared_ptr<const std::string>& payload,
                                uint64_t time_ns, bool incremental) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = subscription_of_.find(channel);
  if (it == subscription_of_.end()) return false;
  if (incremental && awaiting_snapshot_.count(channel)) return false;
  Frame f;
  f.binary = true;
  f.subscription = it->second;
  f.channel = channel;
  f.payload = payload;
  f.time_ns = time_ns;
  if (!incremental) stale_.erase(channel);
  return pushLocked(std::move(f), incremental);
}

bool ClientSession::sendSnapshot(uint32_t channel, const std::shared_ptr<const std::string>& payload,
                                 uint64_t time_ns, bool everyone) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!everyone && !awaiting_snapshot_.count(channel)) return false;
    awaiting_snapshot_.erase(channel);
  }
  return sendMessage(channel, payload, time_ns, false);
}

std::string ClientSession::subscribe(uint32_t subscription_id, uint32_t channel) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (channel_of_.count(subscription_id))
    return "subscription id " + std::to_string(subscription_id) + " in use";
  if (subscription_of_.count(channel)) return "channel " + std::to_string(channel) + " already subscribed";
  if (channel_of_.size() >= limits_.max_subscriptions) return "too many subscriptions";
  channel_of_[subscription_id] = channel;
  subscription_of_[channel] = subscription_id;
  awaiting_snapshot_.insert(channel);  // incremental channels start from a snapshot
  return "";
}

bool ClientSession::unsubscribe(uint32_t subscription_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = channel_of_.find(subscription_id);
  if (it == channel_of_.end()) return false;
  subscription_of_.erase(it->second);
  awaiting_snapshot_.erase(it->second);
  stale_.erase(it->second);
  channel_of_.erase(it);
  return true;
}

bool ClientSession::subscribed(uint32_t channel) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return subscription_of_.count(channel) > 0;
}

void ClientSession::awaitSnapshot(uint32_t channel) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (subscription_of_.count(channel)) awaiting_snapshot_.insert(channel);
}

bool ClientSession::awaitsSnapshot(uint32_t channel) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return subscription_of_.count(channel) && awaiting_snapshot_.count(channel);
}

SessionCounters ClientSession::counters() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counters_;
}

void ClientSession::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return closed_ || !queue_.empty(); });
    if (closed_) return;
    Frame f = std::move(queue_.front());
    queue_.pop_front();
    queued_bytes_ -= f.size();
    lock.unlock();
    const bool ok = f.binary ? writer_(true, messageDataFrame(f.subscription, f.time_ns, *f.payload))
                             : writer_(false, f.text);
    lock.lock();
    if (!ok) {
      ++counters_.write_errors;
      failed_ = true;  // the connection is gone or stuck past the write timeout: send nothing more
      queue_.clear();
      queued_bytes_ = 0;
      return;
    }
    ++counters_.messages_sent;
    counters_.bytes_sent += f.size();
    if (queue_.empty() && !stale_.empty() && resend_) {
      const std::set<uint32_t> stale = std::exchange(stale_, {});
      lock.unlock();
      for (uint32_t channel : stale) resend_(*this, channel);
      lock.lock();
    }
  }
}

}  // namespace rgbdmap::viewer
