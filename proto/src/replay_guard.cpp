// Sliding-window replay protection (as in IPsec/DTLS anti-replay), per sender and session.
#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap::msg {

Status ReplayGuard::check(const Header& header, int stream) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (header.seq < 0) return Status::failure("negative seq");
  const std::string key = header.sender + '\n' + std::to_string(stream);
  auto it = senders_.find(key);
  if (it == senders_.end() && senders_.size() >= max_senders_) return Status::failure("too many senders");
  if (it == senders_.end() || header.session > it->second.session) {
    State fresh;
    fresh.session = header.session;
    fresh.highest = header.seq;
    fresh.window = 1;
    senders_[key] = fresh;
    return Status::success();
  }
  State& s = it->second;
  if (header.session < s.session) return Status::failure("older session");
  if (header.seq > s.highest) {
    const int64_t shift = header.seq - s.highest;
    s.window = shift >= kWindow ? 1 : (s.window << shift) | 1;
    s.highest = header.seq;
    return Status::success();
  }
  const int64_t age = s.highest - header.seq;
  if (age >= kWindow) return Status::failure("older than the window");
  const uint64_t bit = uint64_t{1} << age;
  if (s.window & bit) return Status::failure("duplicate");
  s.window |= bit;
  return Status::success();
}

}  // namespace rgbdmap::msg
