// MapServer: wires the parts together and owns their lifetimes.
//   transport (receive thread) -> TransportGate -> Inbox -> IngestQueue (ingest worker) -> IngestPipeline
//   IngestPipeline -> MapOptimizer (its worker: pose graph, bundle adjustment) -> IngestQueue ->
//   IngestPipeline -> PoseCorrections
//   IngestPipeline -> MapWorker (octree, slices, map stream); StatusPublisher; all send via RobotPublisher.
#include "rgbdmap/server/map_server.hpp"

#include <algorithm>
#include <chrono>
#include <map>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/ingest/ingest_pipeline.hpp"
#include "rgbdmap/ingest/ingest_queue.hpp"
#include "rgbdmap/intake/inbox.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/intake/transport_gate.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/workers/map_optimizer.hpp"
#include "rgbdmap/workers/map_worker.hpp"
#include "rgbdmap/workers/memory_trim.hpp"
#include "rgbdmap/workers/robot_publisher.hpp"
#include "rgbdmap/workers/status_publisher.hpp"
#include "rgbdmap/workers/store_retry.hpp"

namespace rgbdmap {

namespace {
/// How often the ingest worker looks for keyframes that waited reorder_timeout_s: a quarter of it, at
/// least every second.
double reorderTick(const MapServerConfig& config) {
  return std::clamp(config.reorder_timeout_s / 4.0, 0.05, 1.0);
}

void fillStoreStats(const MapStoreHealth& h, MapServerStats* s) {
  s->store_failed = h.failed;
  s->store_error = h.error;
  s->store_failures = h.failures;
  s->store_recover_attempts = h.recover_attempts;
  s->store_recoveries = h.recoveries;
}
/// The inbox's side of the ingest queue (a stopped queue ignores what it is given).
InboxQueue inboxQueue(IngestQueue& queue) {
  InboxQueue q;
  q.hello = [&queue](msg::Hello hello) { queue.pushHello(std::move(hello)); };
  q.keyframe = [&queue](msg::Keyframe keyframe, size_t bytes) {
    switch (queue.pushKeyframe(std::move(keyframe), bytes)) {
      case IngestQueue::Pushed::kFull:
        return RobotQueues::Pushed::kFull;
      case IngestQueue::Pushed::kDuplicate:
        return RobotQueues::Pushed::kDuplicate;
      case IngestQueue::Pushed::kQueued:
      case IngestQueue::Pushed::kStopped:
        break;
    }
    return RobotQueues::Pushed::kQueued;
  };
  q.demote = [&queue](const std::string& robot) { queue.demote(robot); };
  return q;
}
}  // namespace

struct MapServer::Impl {
  Impl(MapServerConfig c, transport::Transport& t, msg::KeyStore k)
      : config(std::move(c)),
        transport(t),
        keys(std::move(k)),
        server_session(msg::newSessionId()),
        publisher(transport, keys, server_session, registry),
        pipeline(config, registry, publisher, server_session / 1000000 * 1000000),
        queue({config.robot_queue_capacity, config.robot_queue_bytes, config.ingest_queue_capacity},
              reorderTick(config), pipeline),
        inbox(InboxConfig{config.robots, config.robot_max_keyframes_per_s, config.robot_keyframe_burst, {}},
              keys, registry, inboxQueue(queue)),
        status(config.status_period_s, registry, publisher, [this] { return pipeline.graphRevision(); }),
        gate([this](const std::string& channel, const uint8_t* data, size_t size) {
          inbox.onMessage(channel, data, size);
        }) {
    status.setRejectCounts([this] { return inbox.rejectCounts(); });
    status.setPlacementSource([this] { return pipeline.placedRobots(); });
    inbox.setChunkAckSink(
        [this](const std::string& robot, const msg::ChunkAck& ack) { publisher.publish(robot, ack); });
    inbox.setKeyframeAckSink(
        [this](const std::string& robot, const msg::KeyframeAck& ack) { publisher.publish(robot, ack); });
    pipeline.setAnswerSink([this](const std::string& robot, int64_t session, int keyframe_id, bool accepted,
                                  const std::string& reason) {
      inbox.noteAnswer(robot, session, keyframe_id, accepted, reason);
    });
    inbox.setNoticeSink([this](const std::string& robot, const msg::ServerStatus& notice) {
      publisher.publishNotice(robot, notice);
    });
  }

  Status openAndRestore();
  void startWorkers();
  Status subscribe();
  /// The ingest queue idle, then a global BA of every map changed since its last one; false at the deadline.
  bool waitOptimized(std::chrono::steady_clock::time_point deadline);

  MapServerConfig config;
  transport::Transport& transport;
  msg::KeyStore keys;
  int64_t server_session;
  RobotRegistry registry;
  RobotPublisher publisher;
  IngestPipeline pipeline;
  IngestQueue queue;
  Inbox inbox;
  StatusPublisher status;
  TransportGate gate;
  std::unique_ptr<MapStore> store;
  std::unique_ptr<MapWorker> map_worker;  ///< null when occupancy is off
  std::unique_ptr<MapOptimizer> optimizer;
  std::unique_ptr<StoreRetry> store_retry;  ///< MapStore::recover() while the store is failed
  std::unique_ptr<MemoryTrim> memory_trim;  ///< null when server.memory_trim_period_s is 0
  bool started = false;
};

Status MapServer::Impl::openAndRestore() {
  if (const std::string problems = config.validate(); !problems.empty())
    return Status::failure("server configuration: " + problems);
  MapStoreOptions store_options;
  store_options.sync = config.store_sync;
  auto opened = MapStore::open(config.map_dir, store_options);
  if (!opened) return Status::failure(opened.error());
  store = std::move(*opened);
  pipeline.attach(store.get(),
                  [this](OptimizerBatch batch) { queue.noteSubmitted(optimizer->submit(std::move(batch))); });
  return pipeline.restore();
}

/// The map worker (given the restored keyframes), the optimiser, the ingest worker and the status thread.
void MapServer::Impl::startWorkers() {
  if (config.occupancy_enabled) {
    MapWorkerPublishers publishers;
    publishers.slice = [this](const std::string& robot, const msg::OccupancySlice& slice) {
      publisher.publish(robot, slice);
    };
    publishers.map = [this](const std::string& robot, const msg::MapUpdate& update) {
      publisher.publish(robot, update);
    };
    map_worker = std::make_unique<MapWorker>(mapWorkerConfig(config), *store, std::move(publishers));
    pipeline.startFeeding(map_worker.get());
    map_worker->start();
  }
  optimizer = std::make_unique<MapOptimizer>(
      MapOptimizerConfig{config.graph, config.ba, config.background_nice, pipeline.featureCache()},
      [this](const std::shared_ptr<const MapOptimization>& result) { queue.pushOptimized(result); });
  queue.start();
  status.setStateSource([this] { return store->health().failed ? "store failed" : "running"; });
  status.start();
  store_retry = std::make_unique<StoreRetry>(config.store_retry_s, *store);
  store_retry->start();
  if (config.memory_trim_period_s > 0.0) {
    memory_trim = std::make_unique<MemoryTrim>(config.memory_trim_period_s);
    memory_trim->start();
  }
  started = true;
  pipeline.submitRestoredLoops();
}

Status MapServer::Impl::subscribe() {
  gate.open();
  std::vector<std::string> patterns;
  // Every robot's channels (LCM: a pattern; DDS: the topics other participants publish, as they appear):
  // a robot that is not served, or signs with another key, is then heard, counted, named in the log and
  // told (the inbox refuses its messages) instead of being silence. A transport without patterns: the
  // listed robots' channels.
  if (config.robots.empty()) {
    patterns.push_back("rgbdmap/*");
  } else if (!transport.subscribe("rgbdmap/*", gate.handler())) {
    for (const std::string& robot : config.robots)
      for (const auto type : {msg::MessageType::kHello, msg::MessageType::kHeartbeat,
                              msg::MessageType::kKeyframe, msg::MessageType::kKeyframeChunk})
        patterns.push_back(*msg::channelFor(type, robot));
  }
  for (const std::string& p : patterns)
    if (const Status s = transport.subscribe(p, gate.handler()); !s)
      return Status::failure("subscribe " + p + ": " + s.error() +
                             (config.robots.empty() ? " (list the robots in the configuration)" : ""));
  log::info(
      "server: serving ",
      config.robots.empty() ? std::string("any robot") : std::to_string(config.robots.size()) + " robot(s)",
      " from ", config.map_dir);
  return Status::success();
}

// ---------------------------------------------------------------------------------------------------------

MapServer::MapServer(MapServerConfig config, transport::Transport& transport, msg::KeyStore keys)
    : impl_(std::make_unique<Impl>(std::move(config), transport, std::move(keys))) {}

MapServer::~MapServer() { stop(); }

Status MapServer::start() {
  Impl& m = *impl_;
  if (m.started) return Status::failure("server already started");
  if (const Status s = m.openAndRestore(); !s) return s;
  m.startWorkers();
  // A frozen map is served as it was written: the restored loops' solve and a global bundle adjustment
  // (what the session that wrote it ended with) come before any robot is placed in it.
  if (m.config.frozen_map && !m.pipeline.keyframes().empty() &&
      !m.waitOptimized(std::chrono::steady_clock::now() + std::chrono::seconds(120)))
    log::warn("server: the restored map was not refined within 120 s; robots are placed in it as it is");
  return m.subscribe();
}

void MapServer::stop() {
  Impl& m = *impl_;
  m.gate.close();
  if (m.optimizer) m.optimizer->stop();
  m.queue.stop();
  m.pipeline.onStop();
  m.status.stop();
  if (m.store_retry) m.store_retry->stop();
  if (m.memory_trim) m.memory_trim->stop();
  if (m.map_worker) m.map_worker->stop();
}

bool MapServer::Impl::waitOptimized(std::chrono::steady_clock::time_point deadline) {
  if (!queue.waitIdleUntil(deadline)) return false;
  // A map that changed since its last global bundle adjustment gets one now (a quiet map would get it
  // after ba.global_when_idle_s anyway): idle means nothing left to refine.
  if (optimizer && optimizer->globalDue()) {
    OptimizerBatch global;
    global.global = true;
    queue.noteSubmitted(optimizer->submit(std::move(global)));
    if (!queue.waitIdleUntil(deadline)) return false;
  }
  return true;
}

bool MapServer::waitIdle(double timeout_s) {
  Impl& m = *impl_;
  using Clock = std::chrono::steady_clock;
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  if (!m.waitOptimized(deadline)) return false;
  if (!m.map_worker) return true;
  return m.map_worker->waitIdle(
      std::max(0.0, std::chrono::duration<double>(deadline - Clock::now()).count()));
}

bool MapServer::flushMapStreams(double timeout_s) {
  Impl& m = *impl_;
  if (!m.map_worker) return true;
  m.map_worker->flushStreams();
  return m.map_worker->waitIdle(timeout_s);
}

msg::ServerStatus MapServer::status() const { return impl_->status.status(); }

MapServerStats MapServer::stats() const {
  const Impl& m = *impl_;
  IngestReport ingest = m.pipeline.stats();
  MapServerStats s;
  static_cast<IngestStats&>(s) = ingest.ingest;
  s.ba = ingest.ba;
  s.hello_hold = ingest.hello_hold;
  s.robots = std::move(ingest.robots);
  s.inbox = m.inbox.stats();
  for (ServerRobotStats& r : s.robots) {
    r.keyframes_queued = static_cast<int>(m.queue.queued(r.robot_id));
    r.keyframes_queued_max = static_cast<int>(m.queue.queuedHighWater(r.robot_id));
  }
  if (m.store) fillStoreStats(m.store->health(), &s);
  if (m.memory_trim) {
    const MemoryTrimStats t = m.memory_trim->stats();
    s.memory_trims = t.trims;
    s.memory_trim_released_bytes = t.released_bytes;
    s.memory_trim_cpu_ms = t.cpu_ms;
  }
  // Outside the server's state lock: counting the octree's leaves must not hold up the ingest worker.
  if (m.map_worker) m.map_worker->fillStats(&s);
  return s;
}

std::vector<ServerKeyframe> MapServer::keyframes() const { return impl_->pipeline.keyframes(); }

std::vector<ServerLoop> MapServer::loops() const { return impl_->pipeline.loops(); }

std::vector<std::vector<std::string>> MapServer::mergedMaps() const {
  const MapServerStats s = stats();
  std::map<int, std::vector<std::string>> by_map;
  for (const ServerRobotStats& r : s.robots)
    if (r.map_id >= 0) by_map[r.map_id].push_back(r.robot_id);
  std::vector<std::vector<std::string>> out;
  for (auto& [id, robots] : by_map) out.push_back(std::move(robots));
  return out;
}

Status MapServer::writeMapOutputs(const std::string& out_dir) const {
  if (!impl_->map_worker)
    return Status::failure("the occupancy map is off (occupancy_enabled: false) or not started");
  return impl_->map_worker->writeOutputs(out_dir, keyframes());
}

std::vector<double> MapServer::ingestTimesMs() const { return impl_->pipeline.ingestTimesMs(); }

}  // namespace rgbdmap
