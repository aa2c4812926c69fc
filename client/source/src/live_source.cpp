// Newest-frame-wins reading of live sources, paced replay of recordings, frame ranges.
#include "rgbdmap/source/live_source.hpp"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace rgbdmap {

struct LatestFrameSource::State {
  std::unique_ptr<FrameSource> inner;
  mutable std::mutex mutex;
  std::condition_variable cv;
  std::optional<FrameRead> pending;  ///< the newest frame nobody has taken yet
  std::optional<FrameRead> last;     ///< kEnd / kFailed once the inner source stopped
  bool closing = false;
  LatestFrameStats stats;
  std::thread reader;

  void run() {
    for (;;) {
      FrameRead read = inner->next();
      std::lock_guard<std::mutex> lock(mutex);
      if (closing || read.kind == FrameRead::Kind::kEnd || read.kind == FrameRead::Kind::kFailed) {
        last = closing ? FrameRead::end() : std::move(read);
        cv.notify_all();
        return;
      }
      ++stats.produced;
      if (pending) ++stats.dropped;
      pending = std::move(read);
      stats.max_pending = std::max<size_t>(stats.max_pending, 1);
      cv.notify_all();
    }
  }
};

LatestFrameSource::LatestFrameSource(std::unique_ptr<FrameSource> live) : state_(std::make_unique<State>()) {
  state_->inner = std::move(live);
  state_->reader = std::thread([s = state_.get()] { s->run(); });
}

LatestFrameSource::~LatestFrameSource() {
  close();
  if (state_->reader.joinable()) state_->reader.join();
}

FrameRead LatestFrameSource::next() {
  std::unique_lock<std::mutex> lock(state_->mutex);
  state_->cv.wait(lock, [this] { return state_->pending || state_->last || state_->closing; });
  if (state_->pending) {
    FrameRead read = std::move(*state_->pending);
    state_->pending.reset();
    ++state_->stats.delivered;
    return read;
  }
  return state_->last ? *state_->last : FrameRead::end();
}

std::optional<CameraIntrinsics> LatestFrameSource::camera() const { return state_->inner->camera(); }
std::string LatestFrameSource::describe() const { return state_->inner->describe(); }

void LatestFrameSource::close() {
  {
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->closing = true;
    state_->pending.reset();
  }
  state_->cv.notify_all();
  state_->inner->close();
}

LatestFrameStats LatestFrameSource::stats() const {
  std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->stats;
}

std::unique_ptr<FrameSource> makeLatestFrameSource(std::unique_ptr<FrameSource> live) {
  return std::make_unique<LatestFrameSource>(std::move(live));
}

namespace {

using Clock = std::chrono::steady_clock;

/// Forwards everything to the wrapped source; subclasses change next().
class ForwardingSource : public FrameSource {
 public:
  explicit ForwardingSource(std::unique_ptr<FrameSource> inner) : inner_(std::move(inner)) {}
  bool live() const override { return inner_->live(); }
  std::optional<CameraIntrinsics> camera() const override { return inner_->camera(); }
  std::string describe() const override { return inner_->describe(); }
  size_t sizeHint() const override { return inner_->sizeHint(); }
  size_t droppedFrames() const override { return inner_->droppedFrames(); }
  std::optional<Trajectory> groundTruth() const override { return inner_->groundTruth(); }
  void close() override { inner_->close(); }

 protected:
  std::unique_ptr<FrameSource> inner_;
};

class PacedSource : public ForwardingSource {
 public:
  using ForwardingSource::ForwardingSource;
  bool live() const override { return true; }
  size_t sizeHint() const override { return 0; }
  std::string describe() const override { return inner_->describe() + ", replayed live"; }
  void close() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    cv_.notify_all();
    inner_->close();
  }

  FrameRead next() override {
    FrameRead read = inner_->next();
    if (read.kind != FrameRead::Kind::kFrame) return read;
    if (!t0_) {
      t0_ = read.frame.timestamp;
      wall0_ = Clock::now();
    }
    const auto due = wall0_ + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(std::max(0.0, read.frame.timestamp - *t0_)));
    std::unique_lock<std::mutex> lock(mutex_);
    if (cv_.wait_until(lock, due, [this] { return closed_; })) return FrameRead::end();
    return read;
  }

 private:
  std::optional<double> t0_;
  Clock::time_point wall0_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool closed_ = false;
};

class RangeSource : public ForwardingSource {
 public:
  RangeSource(std::unique_ptr<FrameSource> inner, size_t first, long long end)
      : ForwardingSource(std::move(inner)), first_(first), end_(end) {}
  size_t sizeHint() const override {
    const size_t n = inner_->sizeHint();
    if (n == 0) return end_ >= 0 ? static_cast<size_t>(end_) - first_ : 0;
    const size_t stop = end_ >= 0 ? std::min(n, static_cast<size_t>(end_)) : n;
    return stop > first_ ? stop - first_ : 0;
  }
  FrameRead next() override {
    for (;;) {
      if (end_ >= 0 && position_ >= static_cast<size_t>(end_)) return FrameRead::end();
      FrameRead read = inner_->next();
      if (read.kind == FrameRead::Kind::kEnd || read.kind == FrameRead::Kind::kFailed) return read;
      if (position_++ >= first_) return read;
    }
  }

 private:
  size_t first_;
  long long end_;
  size_t position_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> makePacedSource(std::unique_ptr<FrameSource> recording) {
  return std::make_unique<PacedSource>(std::move(recording));
}

std::unique_ptr<FrameSource> makeRangeSource(std::unique_ptr<FrameSource> source, size_t first,
                                             long long end) {
  return std::make_unique<RangeSource>(std::move(source), first, end);
}

}  // namespace rgbdmap
