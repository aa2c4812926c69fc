#include "rgbdmap/graph/pose_graph_optimizer.hpp"

#include <chrono>
#include <utility>

namespace rgbdmap {

PoseGraphOptimizer::PoseGraphOptimizer(PoseGraphConfig config, Callback callback)
    : config_(config), callback_(std::move(callback)) {
  worker_ = std::thread([this] { run(); });
}

PoseGraphOptimizer::~PoseGraphOptimizer() { stop(); }

uint64_t PoseGraphOptimizer::submit(PoseGraph snapshot) {
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return 0;
    revision = next_revision_++;
    pending_ = std::move(snapshot);
    pending_revision_ = revision;
  }
  wake_.notify_one();
  return revision;
}

std::shared_ptr<const OptimizedPoses> PoseGraphOptimizer::latestResult() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

bool PoseGraphOptimizer::waitForRevision(uint64_t revision, double timeout_s) const {
  std::unique_lock<std::mutex> lock(mutex_);
  return done_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                        [&] { return stopping_ || (latest_ && latest_->revision >= revision); }) &&
         latest_ && latest_->revision >= revision;
}

void PoseGraphOptimizer::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    pending_.reset();
  }
  cancel_ = true;
  wake_.notify_all();
  done_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void PoseGraphOptimizer::run() {
  for (;;) {
    PoseGraph graph;
    uint64_t revision = 0;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || pending_.has_value(); });
      if (stopping_) return;
      graph = std::move(*pending_);
      revision = pending_revision_;
      pending_.reset();
    }
    auto result = std::make_shared<OptimizedPoses>();
    result->revision = revision;
    auto report = graph.optimize(config_, &cancel_);
    if (!report.ok() || report->cancelled) {
      if (cancel_) return;
      result->error = report.ok() ? "cancelled" : report.error();
    } else {
      result->ok = true;
      result->report = *report;
      result->T_map_kf = graph.poses();
      result->disabled_edges = graph.disabledEdges();
      result->components = graph.components();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      latest_ = result;
    }
    done_.notify_all();
    if (callback_) callback_(result);
  }
}

}  // namespace rgbdmap
