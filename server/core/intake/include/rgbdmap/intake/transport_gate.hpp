#pragma once
// Lets a transport's handler reach the server only while it is running. The Transport API cannot
// unsubscribe, and a transport may outlive a stopped server in the same process: the handlers given to
// subscribe() hold only a weak reference to the gate and do nothing once it is closed or gone.
#include <memory>
#include <mutex>

#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {

class TransportGate {
 public:
  /// `target` is called for every message while the gate is open.
  explicit TransportGate(transport::Transport::Handler target);

  void open();
  /// After close() returns, no call to the target runs or will run (it waits for one in progress).
  void close();
  /// A handler for Transport::subscribe(); safe to call after the gate is destroyed.
  transport::Transport::Handler handler() const;

 private:
  struct State {
    std::mutex mutex;
    bool open = false;
    transport::Transport::Handler target;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

}  // namespace rgbdmap
