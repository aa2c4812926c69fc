#include "rgbdmap/cli/progress.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>

namespace rgbdmap::app {

Progress::Progress(std::string label, size_t total)
    : label_(std::move(label)),
      total_(total),
      enabled_(isatty(STDERR_FILENO) && !std::getenv("CI")),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

void Progress::update(size_t done) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (done < total_ && now - last_ < std::chrono::milliseconds(200)) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = elapsed > 0 ? done / elapsed : 0;
  std::string note = note_ ? note_() : "";
  if (!note.empty()) note = ", " + note;
  if (total_ == 0) {  // a live source: no end known
    std::fprintf(stderr, "\r%s: %zu frames, %.1f frames/s%s   ", label_.c_str(), done, rate, note.c_str());
    std::fflush(stderr);
    return;
  }
  const double eta = rate > 0 && done < total_ ? (total_ - done) / rate : 0;
  std::fprintf(stderr, "\r%s: %zu/%zu frames, %.1f frames/s, ETA %.0f s%s   ", label_.c_str(), done, total_,
               rate, eta, note.c_str());
  std::fflush(stderr);
}

void Progress::finish() {
  if (enabled_) std::fprintf(stderr, "\n");
}

}  // namespace rgbdmap::app
