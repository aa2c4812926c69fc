#pragma once
// Progress for long runs: a self-updating line (done/total, rate, ETA, a note) on an interactive terminal;
// silent when stderr is not a terminal or CI is set, so logs stay clean.
#include <chrono>
#include <cstddef>
#include <functional>
#include <string>

namespace rgbdmap::app {

class Progress {
 public:
  Progress(std::string label, size_t total);
  void update(size_t done);
  void finish();
  /// A few words appended to the line when it is drawn (e.g. the link's state); asked only then.
  void setNote(std::function<std::string()> note) { note_ = std::move(note); }

 private:
  std::string label_;
  size_t total_;
  bool enabled_;
  std::function<std::string()> note_;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace rgbdmap::app
