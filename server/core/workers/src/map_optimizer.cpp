// MapOptimizer: the pending batches -> MapBackend on the worker thread -> one result per run to the callback.
#include "rgbdmap/workers/map_optimizer.hpp"

#include <utility>

namespace rgbdmap {

MapOptimizer::MapOptimizer(MapOptimizerConfig config, Callback callback)
    : global_when_idle_s_(config.ba.global_when_idle_s),
      callback_(std::move(callback)),
      backend_({config.graph, config.ba, std::move(config.features)}),
      worker_({"rgbdmap-optim", 0, global_when_idle_s_ > 0 ? 0.5 : 0.0, [this] { onIdle(); }, config.nice}) {
  worker_.start();
}

MapOptimizer::~MapOptimizer() { stop(); }

uint64_t MapOptimizer::submit(OptimizerBatch batch) {
  uint64_t revision = 0;
  bool post = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return 0;
    revision = next_revision_++;
    pending_.append(std::move(batch));
    pending_revision_ = revision;
    last_batch_ = std::chrono::steady_clock::now();
    post = !std::exchange(task_queued_, true);
  }
  if (post) worker_.post([this] { processPending(); });
  return revision;
}

bool MapOptimizer::globalDue() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return global_due_;
}

void MapOptimizer::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    pending_ = {};
  }
  backend_.cancel();
  worker_.stop();
}

void MapOptimizer::processPending() {
  OptimizerBatch b;
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    b = std::exchange(pending_, {});
    revision = pending_revision_;
    task_queued_ = false;
  }
  publish(revision, backend_.runBatch(b));
}

void MapOptimizer::onIdle() {
  uint64_t revision = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const double quiet_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - last_batch_).count();
    if (stopping_ || task_queued_ || quiet_s < global_when_idle_s_ || !global_due_) return;
    // A result of its own: robots take corrections only from a newer revision than they have.
    revision = pending_revision_ = next_revision_++;
  }
  publish(revision, backend_.runIdle());
}

void MapOptimizer::publish(uint64_t revision, std::shared_ptr<MapOptimization> result) {
  if (!result) return;  // cancelled
  result->revision = revision;
  result->graph.revision = revision;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    global_due_ = backend_.globalDue();
  }
  if (callback_) callback_(result);
}

}  // namespace rgbdmap
