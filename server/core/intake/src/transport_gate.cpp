#include "rgbdmap/intake/transport_gate.hpp"

#include <utility>

namespace rgbdmap {

TransportGate::TransportGate(transport::Transport::Handler target) { state_->target = std::move(target); }

void TransportGate::open() {
  std::lock_guard<std::mutex> lock(state_->mutex);
  state_->open = true;
}

void TransportGate::close() {
  std::lock_guard<std::mutex> lock(state_->mutex);
  state_->open = false;
}

transport::Transport::Handler TransportGate::handler() const {
  std::weak_ptr<State> weak = state_;
  return [weak](const std::string& channel, const uint8_t* data, size_t size) {
    const auto state = weak.lock();
    if (!state) return;
    std::lock_guard<std::mutex> lock(state->mutex);
    if (state->open) state->target(channel, data, size);
  };
}

}  // namespace rgbdmap
