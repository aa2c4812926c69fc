#pragma once
// Subscriptions of one transport: pattern -> handlers. Matching handlers are copied out under the lock so
// they run without it (a handler may subscribe or publish).
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::transport {

class HandlerTable {
 public:
  void add(const std::string& pattern, Transport::Handler handler) {
    std::lock_guard<std::mutex> lock(mutex_);
    entries_.emplace_back(pattern, std::make_shared<Transport::Handler>(std::move(handler)));
  }

  std::vector<std::shared_ptr<Transport::Handler>> matching(const std::string& channel) const {
    std::vector<std::shared_ptr<Transport::Handler>> out;
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [pattern, handler] : entries_) {
      if (channelMatches(pattern, channel)) out.push_back(handler);
    }
    return out;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, std::shared_ptr<Transport::Handler>>> entries_;
};

}  // namespace rgbdmap::transport
