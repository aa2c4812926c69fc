#include "rgbdmap/cli/signal_thread.hpp"

#include <pthread.h>

#include <cstdlib>

namespace rgbdmap::cli {

void waitForSignal(const sigset_t& signals, double timeout_s) {
  if (timeout_s <= 0) {
    int sig = 0;
    sigwait(&signals, &sig);
    return;
  }
  timespec ts;
  ts.tv_sec = static_cast<time_t>(timeout_s);
  ts.tv_nsec = static_cast<long>((timeout_s - static_cast<double>(ts.tv_sec)) * 1e9);
  sigtimedwait(&signals, nullptr, &ts);
}

SignalThread::SignalThread() {
  sigemptyset(&set_);
  for (int s : {SIGINT, SIGTERM, SIGUSR1}) sigaddset(&set_, s);
  pthread_sigmask(SIG_BLOCK, &set_, nullptr);  // before any other thread exists: they inherit it
}

void SignalThread::start(std::function<void(int)> on_stop) {
  thread_ = std::thread([this, on_stop = std::move(on_stop)] {
    for (int count = 0;; ++count) {
      int sig = 0;
      if (sigwait(&set_, &sig) != 0 || sig == SIGUSR1) return;  // SIGUSR1: the destructor's
      if (count > 0) std::_Exit(130);
      on_stop(sig);
    }
  });
}

SignalThread::~SignalThread() {
  if (!thread_.joinable()) return;
  pthread_kill(thread_.native_handle(), SIGUSR1);
  thread_.join();
}

}  // namespace rgbdmap::cli
