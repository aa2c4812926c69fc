#include "rgbdmap/graph/pose_graph_optimizer.hpp"

#include <chrono>
#include <utility>

namespace rgbdmap {

PoseGraphOptimizer::PoseGraphOptimizer(PoseGraphConfig config, Callback callback, SolveStarted on_solve)
    : config_(config), callback_(std::move(callback)), on_solve_(std::move(on_solve)) {
  worker_.start();
}

PoseGraphOptimizer::~PoseGraphOptimizer() { stop(); }

uint64_t PoseGraphOptimizer::submit(PoseGraph snapshot) {
  uint64_t revision = 0;
  bool solve_queued = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return 0;
    revision = next_revision_++;
    solve_queued = pending_.has_value();  // its task, not started yet, will take this newer snapshot
    pending_ = std::move(snapshot);
    pending_revision_ = revision;
  }
  if (!solve_queued) worker_.post([this] { solvePending(); });
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
  done_.notify_all();
  worker_.stop();
}

void PoseGraphOptimizer::solvePending() {
  PoseGraph graph;
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ || !pending_) return;
    graph = std::move(*pending_);
    revision = pending_revision_;
    pending_.reset();
  }
  if (on_solve_) on_solve_(revision);
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

}  // namespace rgbdmap
