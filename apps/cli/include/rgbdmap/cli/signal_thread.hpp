#pragma once
// SIGINT/SIGTERM for a program that stops cleanly: the signals are blocked in every thread (construct this
// before any other thread starts: they inherit the mask) and taken by one waiting thread. The first calls
// `on_stop` (ask the run to stop; outputs are still written), a second one exits at once (status 130).
#include <csignal>
#include <functional>
#include <thread>

namespace rgbdmap::cli {

/// Blocks the calling thread until one of `signals` (blocked in every thread beforehand) arrives or
/// `timeout_s` passes (0: no timeout). For programs that only wait for Ctrl-C.
void waitForSignal(const sigset_t& signals, double timeout_s);

class SignalThread {
 public:
  SignalThread();
  ~SignalThread();  ///< ends the waiting thread quietly
  SignalThread(const SignalThread&) = delete;
  SignalThread& operator=(const SignalThread&) = delete;
  /// Starts waiting; `on_stop(signal)` runs on the waiting thread.
  void start(std::function<void(int)> on_stop);

 private:
  sigset_t set_;
  std::thread thread_;
};

}  // namespace rgbdmap::cli
