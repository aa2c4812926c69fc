// DedupFilter: per-sender FIFO window of recent ids, least recently seen sender evicted first.
#include "rgbdmap/transport/reliable.hpp"

namespace rgbdmap::transport {

bool DedupFilter::accept(uint64_t sender, uint64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = senders_.find(sender);
  if (it == senders_.end()) {
    evictSenderIfNeeded();
    it = senders_.emplace(sender, Window{}).first;
  }
  Window& w = it->second;
  w.last_seen = ++tick_;
  if (!w.ids.insert(id).second) {
    ++duplicates_;
    return false;
  }
  w.order.push_back(id);
  if (w.order.size() > options_.ids_per_sender) {
    w.ids.erase(w.order.front());
    w.order.pop_front();
  }
  return true;
}

void DedupFilter::evictSenderIfNeeded() {
  if (senders_.size() < options_.max_senders || senders_.empty()) return;
  auto oldest = senders_.begin();
  for (auto it = senders_.begin(); it != senders_.end(); ++it) {
    if (it->second.last_seen < oldest->second.last_seen) oldest = it;
  }
  senders_.erase(oldest);
}

uint64_t DedupFilter::duplicates() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return duplicates_;
}

size_t DedupFilter::remembered() const {
  std::lock_guard<std::mutex> lock(mutex_);
  size_t n = 0;
  for (const auto& [sender, w] : senders_) n += w.order.size();
  return n;
}

}  // namespace rgbdmap::transport
