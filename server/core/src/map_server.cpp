#include "rgbdmap/server/map_server.hpp"

#include <pthread.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <set>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include "map_worker.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"
#include "robot_registry.hpp"

namespace rgbdmap {
namespace {

using Clock = std::chrono::steady_clock;

int64_t nowUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// CPU time of the calling thread (ms): what a keyframe costs, whatever else the machine is doing.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(pos);
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

/// "rgbdmap/<robot>/<suffix>" -> (robot, suffix); false for anything else.
bool splitChannel(const std::string& channel, std::string* robot, std::string* suffix) {
  static const std::string kPrefix = "rgbdmap/";
  if (channel.compare(0, kPrefix.size(), kPrefix) != 0) return false;
  const size_t slash = channel.find('/', kPrefix.size());
  if (slash == std::string::npos) return false;
  *robot = channel.substr(kPrefix.size(), slash - kPrefix.size());
  *suffix = channel.substr(slash + 1);
  return !robot->empty() && !suffix->empty();
}

bool isPositiveDefinite(const Mat6& m) {
  if (!m.allFinite() || !m.isApprox(m.transpose(), 1e-9 * (1.0 + m.norm()))) return false;
  const Eigen::LLT<Mat6> llt(0.5 * (m + m.transpose()));
  return llt.info() == Eigen::Success;
}

/// Adds an uncertainty floor to an edge's covariance: information' = (information^-1 + diag(st^2, sr^2))^-1.
/// Information from a refinement's Hessian assumes independent pixel errors and is far too confident
/// (sub-millimetre on a keyframe edge); with it, a few centimetres of real drift look like a 40-sigma outlier
/// and the robust loss and consistency check would throw the true loop away.
Mat6 withCovarianceFloor(const Mat6& information, double sigma_t, double sigma_r) {
  Mat6 floor = Mat6::Zero();
  floor.diagonal() << sigma_t * sigma_t, sigma_t * sigma_t, sigma_t * sigma_t, sigma_r * sigma_r,
      sigma_r * sigma_r, sigma_r * sigma_r;
  const Eigen::LDLT<Mat6> ldlt(0.5 * (information + information.transpose()));
  const Mat6 cov = ldlt.solve(Mat6::Identity());
  Mat6 out = (0.5 * (cov + cov.transpose()) + floor).inverse();
  return 0.5 * (out + out.transpose());
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------

struct MapServer::Impl {
  struct Event {
    enum class Kind { kHello, kKeyframe, kOptimized } kind = Kind::kHello;
    msg::Hello hello;
    msg::Keyframe keyframe;
    size_t bytes = 0;
    std::shared_ptr<const OptimizedPoses> result;
  };
  /// An odometry chain: one segment of one robot process.
  struct Chain {
    int robot = 0;
    int64_t session = 0;
    int segment = 0;
  };
  struct Node {
    ServerKeyframe kf;
    int robot = -1;
    int chain = -1;
    bool valid = false;  ///< false for ids whose stored record was lost (corrupt), kept as holes
  };
  using NodeKey = std::tuple<int, int64_t, int, int>;  // robot, session, segment, keyframe id

  /// Lets the transport's handler reach the server only while it is running (the Transport API cannot
  /// unsubscribe, and a transport may outlive a stopped server in the same process).
  struct Gate {
    std::mutex mutex;
    Impl* impl = nullptr;
  };

  Impl(MapServerConfig c, transport::Transport& t, msg::KeyStore k)
      : config(std::move(c)),
        transport(t),
        keys(std::move(k)),
        detector(CameraIntrinsics{}, config.loop),
        server_session(msg::newSessionId()),
        revision_base(server_session / 1000000 * 1000000) {}

  // ---- configuration and collaborators
  MapServerConfig config;
  transport::Transport& transport;
  msg::KeyStore keys;
  msg::ReplayGuard guard;
  msg::RejectCounters rejects;
  std::unique_ptr<MapStore> store;
  LoopDetector detector;
  PoseGraph graph;
  std::unique_ptr<PoseGraphOptimizer> optimizer;
  int64_t server_session;
  int64_t revision_base;  ///< graph revisions grow across restarts: start second * 1e6 + solve number
  Clock::time_point started = Clock::now();
  std::shared_ptr<Gate> gate = std::make_shared<Gate>();

  // ---- event queue (receive thread and optimiser callback -> worker)
  std::mutex queue_mutex;
  std::condition_variable queue_cv;
  std::condition_variable idle_cv;
  std::deque<Event> queue;
  size_t queued_keyframes = 0;
  bool busy = false;
  bool stopping = false;
  uint64_t submitted_revision = 0;
  uint64_t applied_revision = 0;

  // ---- map state: written by the worker only, read by stats() etc. under state_mutex
  mutable std::mutex state_mutex;
  RobotRegistry registry;
  std::vector<Chain> chains;
  std::map<std::tuple<int, int64_t, int>, int> chain_of;
  std::vector<Node> nodes;  ///< index = node id
  std::map<NodeKey, int64_t> node_of;
  std::set<NodeKey> refused;  ///< keyframes refused for good (their successors start new chains)
  int64_t next_edge_id = 0;
  MapServerStats counters;  ///< the counting fields; robots and derived fields are filled in stats()
  std::vector<double> ingest_ms;
  std::vector<double> ingest_cpu_ms;
  std::vector<double> verify_ms;
  std::array<std::vector<double>, 3> stage_ms;  ///< decode + features, store, loops + graph
  std::vector<std::vector<int64_t>> components;
  std::atomic<uint64_t> dropped_queue_full{0};
  std::atomic<uint64_t> unknown_robot{0};

  // ---- publishing (worker and status thread)
  std::mutex publish_mutex;
  std::map<std::string, std::unique_ptr<msg::Signer>> signers;

  std::unique_ptr<MapWorker> map_worker;  ///< null when occupancy is off
  std::thread worker;
  std::thread status_thread;
  std::condition_variable status_cv;
  std::mutex status_mutex;
  bool started_threads = false;

  // ------------------------------------------------------------------------------------------------------
  template <typename T>
  void publishTo(const std::string& robot_id, const T& message) {
    const auto channel = msg::channelFor(T::kType, robot_id);
    if (!channel) return;
    std::lock_guard<std::mutex> lock(publish_mutex);
    auto& signer = signers[robot_id];
    if (!signer) {
      const msg::Bytes* key = keys.find(robot_id);
      signer = std::make_unique<msg::Signer>(msg::kServerId, key ? *key : msg::Bytes{}, server_session);
    }
    const auto bytes = signer->seal(message, nowUtime());
    if (!bytes) {
      log::warn("server: cannot seal ", msg::toString(T::kType), " for ", robot_id, ": ", bytes.error());
      return;
    }
    if (const Status s = transport.publish(*channel, *bytes); !s) {
      log::warn("server: publish on ", *channel, " failed: ", s.error());
      return;
    }
    registry.addBytesSent(robot_id, bytes->size());
  }

  void acknowledge(const std::string& robot_id, int keyframe_id, bool accepted, const std::string& reason) {
    msg::KeyframeAck ack;
    ack.robot_id = robot_id;
    ack.keyframe_id = keyframe_id;
    ack.accepted = accepted;
    ack.reason = reason.substr(0, msg::kMaxTextLength);
    publishTo(robot_id, ack);
  }

  // ---- receive thread --------------------------------------------------------------------------------
  void onMessage(const std::string& channel, const uint8_t* data, size_t size) {
    std::string robot, suffix;
    if (!splitChannel(channel, &robot, &suffix)) return;
    const bool to_server = suffix == msg::channelSuffix(msg::MessageType::kHello) ||
                           suffix == msg::channelSuffix(msg::MessageType::kHeartbeat) ||
                           suffix == msg::channelSuffix(msg::MessageType::kKeyframe);
    if (!to_server) return;  // our own messages (udpm:// loops them back under a "rgbdmap/*" subscription)
    auto opened = msg::openEnvelope(data, size, keys, &guard, &rejects);
    if (!opened) return;  // counted and logged (rate-limited) by RejectCounters
    if (opened->header.sender != robot) {
      rejects.add(msg::RejectReason::kHeaderMismatch, "sender '" + opened->header.sender + "' on " + channel);
      return;
    }
    if (!config.robots.empty() &&
        std::find(config.robots.begin(), config.robots.end(), robot) == config.robots.end()) {
      ++unknown_robot;
      return;
    }
    registry.addBytesReceived(robot, size, opened->header.utime);
    switch (opened->type) {
      case msg::MessageType::kHello: {
        auto hello = msg::decodeMessage<msg::Hello>(*opened, &rejects);
        if (!hello) return;
        if (hello->robot_id != robot) {
          rejects.add(msg::RejectReason::kInvalidContent,
                      "hello for '" + hello->robot_id + "' from " + robot);
          return;
        }
        Event e;
        e.kind = Event::Kind::kHello;
        e.hello = std::move(*hello);
        push(std::move(e), false);
        return;
      }
      case msg::MessageType::kHeartbeat:
        (void)msg::decodeMessage<msg::Heartbeat>(*opened, &rejects);
        return;
      case msg::MessageType::kKeyframe: {
        auto keyframe = msg::decodeMessage<msg::Keyframe>(*opened, &rejects);
        if (!keyframe) return;
        if (keyframe->robot_id != robot) {
          rejects.add(msg::RejectReason::kInvalidContent,
                      "keyframe for '" + keyframe->robot_id + "' from " + robot);
          return;
        }
        Event e;
        e.kind = Event::Kind::kKeyframe;
        e.keyframe = std::move(*keyframe);
        e.bytes = size;
        push(std::move(e), true);
        return;
      }
      default:
        rejects.add(msg::RejectReason::kWrongType,
                    std::string(msg::toString(opened->type)) + " on " + channel);
        return;
    }
  }

  void push(Event e, bool is_keyframe) {
    {
      std::lock_guard<std::mutex> lock(queue_mutex);
      if (stopping) return;
      if (is_keyframe) {
        if (queued_keyframes >= config.ingest_queue_capacity) {
          ++dropped_queue_full;  // not acknowledged: the robot sends it again
          return;
        }
        ++queued_keyframes;
      }
      queue.push_back(std::move(e));
    }
    queue_cv.notify_one();
  }

  // ---- worker ----------------------------------------------------------------------------------------
  void run() {
    pthread_setname_np(pthread_self(), "rgbdmap-ingest");
    for (;;) {
      Event e;
      {
        std::unique_lock<std::mutex> lock(queue_mutex);
        idle_cv.notify_all();
        queue_cv.wait(lock, [&] { return stopping || !queue.empty(); });
        if (stopping) return;
        e = std::move(queue.front());
        queue.pop_front();
        if (e.kind == Event::Kind::kKeyframe) --queued_keyframes;
        busy = true;
      }
      switch (e.kind) {
        case Event::Kind::kHello:
          handleHello(e.hello);
          break;
        case Event::Kind::kKeyframe:
          handleKeyframe(e.keyframe);
          break;
        case Event::Kind::kOptimized:
          handleOptimized(*e.result);
          break;
      }
      std::lock_guard<std::mutex> lock(queue_mutex);
      busy = false;
      if (e.kind == Event::Kind::kOptimized)
        applied_revision = std::max(applied_revision, e.result->revision);
    }
  }

  void handleHello(const msg::Hello& hello) {
    std::lock_guard<std::mutex> lock(state_mutex);
    const auto registered = registry.hello(hello.robot_id, hello.header.session, hello.camera);
    if (!registered) {
      log::warn("server: hello from ", hello.robot_id, ": ", registered.error());
      return;
    }
    if (*registered) {
      if (const Status s = registry.save(store->directory()); !s) log::error("server: ", s.error());
      detector.setRobotCamera(registry.index(hello.robot_id), hello.camera);
      log::info("server: robot ", hello.robot_id, " (", hello.software_version, ") joined, session ",
                hello.header.session);
    }
  }

  int chainFor(int robot, int64_t session, int segment) {
    const auto key = std::make_tuple(robot, session, segment);
    const auto it = chain_of.find(key);
    if (it != chain_of.end()) return it->second;
    chains.push_back({robot, session, segment});
    chain_of.emplace(key, static_cast<int>(chains.size() - 1));
    return static_cast<int>(chains.size() - 1);
  }

  Mat6 floored(const Mat6& information) const {
    if (config.edge_sigma_floor_m <= 0.0 && config.edge_sigma_floor_deg <= 0.0) return information;
    return withCovarianceFloor(information, config.edge_sigma_floor_m,
                               config.edge_sigma_floor_deg * M_PI / 180.0);
  }

  Mat6 odometryInformation(const msg::Keyframe& kf) const {
    if (isPositiveDefinite(kf.information)) return floored(kf.information);
    const double st = config.default_odometry_sigma_m;
    const double sr = config.default_odometry_sigma_deg * M_PI / 180.0;
    Mat6 info = Mat6::Zero();
    info.diagonal() << 1 / (st * st), 1 / (st * st), 1 / (st * st), 1 / (sr * sr), 1 / (sr * sr),
        1 / (sr * sr);
    return info;
  }

  /// Adds a stored keyframe to the graph and the detector's state. `detect`: run loop detection (a live
  /// keyframe) or just index it (restore). Returns the accepted loop edges.
  std::vector<LoopEdge> integrate(const StoredKeyframe& stored, const FrameFeatures& features, bool detect,
                                  LoopStats* loop_stats) {
    const msg::Keyframe& kf = stored.keyframe;
    const int robot = registry.index(kf.robot_id);
    const int chain = chainFor(robot, stored.session, kf.segment_id);
    std::optional<int64_t> prev;
    if (kf.previous_keyframe_id >= 0) {
      const auto it = node_of.find({robot, stored.session, kf.segment_id, kf.previous_keyframe_id});
      if (it != node_of.end()) prev = it->second;
    }
    Node node;
    node.valid = true;
    node.robot = robot;
    node.chain = chain;
    node.kf.node_id = stored.node_id;
    node.kf.robot_id = kf.robot_id;
    node.kf.session = stored.session;
    node.kf.segment = kf.segment_id;
    node.kf.keyframe_id = kf.keyframe_id;
    node.kf.timestamp = kf.timestamp;
    node.kf.T_odom_kf = kf.T_odom_cam;
    if (prev) {
      const Node& p = nodes[static_cast<size_t>(*prev)];
      node.kf.T_map_kf = se3::normalized(p.kf.T_map_kf * kf.T_prev_cur);
      node.kf.map_id = p.kf.map_id;
    } else {
      node.kf.T_map_kf = kf.T_odom_cam;  // a new chain starts a map of its own until a loop joins it
      node.kf.map_id = static_cast<int>(stored.node_id);
    }
    if (nodes.size() < static_cast<size_t>(stored.node_id)) nodes.resize(static_cast<size_t>(stored.node_id));
    nodes.push_back(node);
    node_of[{robot, stored.session, kf.segment_id, kf.keyframe_id}] = stored.node_id;

    if (const Status s = graph.addNode(stored.node_id, chain, node.kf.T_map_kf); !s)
      log::error("server: graph node ", stored.node_id, ": ", s.error());
    if (graph.nodes().size() == 1) graph.setFixed(stored.node_id);  // the first keyframe of the first robot
    if (prev) {
      PoseGraphEdge e;
      e.id = next_edge_id++;
      e.from = stored.node_id;
      e.to = *prev;
      e.T_from_to = kf.T_prev_cur.inverse();
      e.information = odometryInformation(kf);
      e.kind = EdgeKind::kOdometry;
      if (const Status s = graph.addEdge(e); !s) log::error("server: odometry edge: ", s.error());
    }
    LoopKeyframe lk;
    lk.id = static_cast<int>(stored.node_id);
    lk.robot_id = robot;
    lk.map_id = node.kf.map_id;
    lk.T_map_kf = node.kf.T_map_kf;
    lk.features = features;
    if (!detect) {
      if (const Status s = detector.restoreKeyframe(std::move(lk)); !s)
        log::error("server: restore: ", s.error());
      return {};
    }
    auto detection = detector.addKeyframe(std::move(lk));
    if (!detection) {
      log::error("server: loop detection for keyframe ", stored.node_id, ": ", detection.error());
      return {};
    }
    if (loop_stats) *loop_stats = detection->stats;
    return detection->edges;
  }

  Status addLoopEdge(const LoopEdge& edge) {
    PoseGraphEdge e;
    e.id = next_edge_id++;
    e.from = edge.from_id;
    e.to = edge.to_id;
    e.T_from_to = edge.T_from_to;
    e.information = isPositiveDefinite(edge.information) ? floored(edge.information) : edge.information;
    const Node& a = nodes[static_cast<size_t>(edge.from_id)];
    const Node& b = nodes[static_cast<size_t>(edge.to_id)];
    e.kind = a.chain != b.chain ? EdgeKind::kInterRobot : EdgeKind::kLoop;
    return graph.addEdge(e);
  }

  void handleKeyframe(const msg::Keyframe& kf) {
    const auto t0 = Clock::now();
    const double cpu0 = threadCpuMs();
    std::unique_lock<std::mutex> lock(state_mutex);
    const int robot = registry.index(kf.robot_id);
    const std::optional<CameraIntrinsics> camera = registry.camera(kf.robot_id);
    if (robot < 0 || !camera) {
      // No Hello yet (lost or reordered): not acknowledged, so the robot sends it again after its Hello.
      registry.countWaitingForHello(kf.robot_id);
      return;
    }
    const int64_t session = kf.header.session;
    const NodeKey key{robot, session, kf.segment_id, kf.keyframe_id};
    if (node_of.count(key) || refused.count(key)) {
      const bool accepted = node_of.count(key) != 0;
      registry.countDuplicate(kf.robot_id);
      lock.unlock();
      acknowledge(kf.robot_id, kf.keyframe_id, accepted, accepted ? "duplicate" : "refused before");
      return;
    }
    if (kf.previous_keyframe_id >= 0) {
      const NodeKey prev{robot, session, kf.segment_id, kf.previous_keyframe_id};
      if (!node_of.count(prev) && !refused.count(prev)) {
        // The predecessor has not arrived yet (a retransmission overtook it): keep the odometry chain whole
        // by waiting for it; this one is not acknowledged and comes again.
        registry.countOutOfOrder(kf.robot_id);
        return;
      }
    }
    auto refuse = [&](const std::string& reason) {
      refused.insert(key);
      ++counters.keyframes_refused;
      registry.countRefused(kf.robot_id);
      lock.unlock();
      log::warn("server: keyframe ", kf.keyframe_id, " of ", kf.robot_id, " refused: ", reason);
      acknowledge(kf.robot_id, kf.keyframe_id, false, reason);
    };
    if (kf.images.width != camera->width || kf.images.height != camera->height)
      return refuse("image size differs from the camera in the robot's Hello");
    const auto t_decode = Clock::now();
    const auto images = msg::decodeKeyframeImages(kf);
    if (!images) return refuse("images: " + images.error());
    const auto features = featuresFromMessage(kf, PinholeCamera(*camera));
    if (!features) return refuse(features.error());

    StoredKeyframe stored;
    stored.node_id = static_cast<int64_t>(nodes.size());
    stored.session = session;
    stored.keyframe = kf;
    const double decode_ms = msSince(t_decode);
    const auto t_store = Clock::now();
    if (const Status s = store->appendKeyframe(stored); !s) {
      log::error("server: cannot store keyframe ", kf.keyframe_id, " of ", kf.robot_id, ": ", s.error());
      return;  // not acknowledged: the robot sends it again
    }
    stored.keyframe.images = {};
    const double store_ms = msSince(t_store);
    acknowledge(kf.robot_id, kf.keyframe_id, true, "");
    const auto t_loops = Clock::now();

    LoopStats loop_stats;
    const std::vector<LoopEdge> edges = integrate(stored, *features, true, &loop_stats);
    if (map_worker) {
      const Node& n = nodes.back();
      map_worker->addKeyframe({n.kf.node_id, n.kf.robot_id, n.kf.map_id, n.kf.T_map_kf, *camera,
                               images->depth, images->color, true});
    }
    counters.loop_candidates += loop_stats.candidates;
    verify_ms.push_back(loop_stats.verify_ms);
    for (int r = 0; r < kLoopRejectionCount; ++r)
      counters.loops_rejected_by_reason[r] += loop_stats.rejected_by_reason[r];
    int added = 0;
    std::vector<StoredLoop> to_store;
    for (const LoopEdge& edge : edges) {
      if (const Status s = addLoopEdge(edge); !s) {
        log::warn("server: loop edge ", edge.from_id, "-", edge.to_id, ": ", s.error());
        continue;
      }
      to_store.push_back(
          {edge.from_id, edge.to_id, edge.T_from_to, edge.information, edge.inliers, edge.motion_measure});
      ++added;
      registry.countLoop(nodes[static_cast<size_t>(edge.from_id)].kf.robot_id);
      if (nodes[static_cast<size_t>(edge.to_id)].robot != robot)
        registry.countLoop(nodes[static_cast<size_t>(edge.to_id)].kf.robot_id);
    }
    // One write and one sync for all of this keyframe's loops (a lost loop edge costs accuracy, not data).
    if (const Status s = store->appendLoops(to_store); !s)
      log::error("server: cannot store loops: ", s.error());
    counters.loops_accepted += added;
    ++counters.keyframes;
    registry.countKeyframe(kf.robot_id);
    if (added > 0) submitOptimization();
    stage_ms[0].push_back(decode_ms);
    stage_ms[1].push_back(store_ms);
    stage_ms[2].push_back(msSince(t_loops));
    ingest_ms.push_back(msSince(t0));
    ingest_cpu_ms.push_back(threadCpuMs() - cpu0);
  }

  void submitOptimization() {
    const uint64_t revision = optimizer->submit(graph);
    std::lock_guard<std::mutex> lock(queue_mutex);
    submitted_revision = std::max(submitted_revision, revision);
  }

  void refreshComponents() {
    components = graph.components();
    for (const auto& component : components) {
      const int map_id = static_cast<int>(component.front());
      for (const int64_t id : component) nodes[static_cast<size_t>(id)].kf.map_id = map_id;
    }
  }

  void handleOptimized(const OptimizedPoses& result) {
    std::unique_lock<std::mutex> lock(state_mutex);
    if (!result.ok) {
      log::warn("server: optimisation ", result.revision, " failed: ", result.error);
      return;
    }
    graph.applyOptimized(result.T_map_kf, result.disabled_edges);
    for (const auto& [id, pose] : graph.poses()) nodes[static_cast<size_t>(id)].kf.T_map_kf = pose;
    refreshComponents();
    for (const Node& n : nodes)
      if (n.valid) detector.updatePose(static_cast<int>(n.kf.node_id), n.kf.map_id, n.kf.T_map_kf);
    ++counters.optimizations;
    counters.last_optimize_ms = result.report.time_ms;
    counters.loops_disabled = static_cast<int>(graph.disabledEdges().size());
    counters.graph_revision = revision_base + static_cast<int64_t>(result.revision);
    // Corrections for each robot's current process: its keyframes and T_map_odom of its newest segment.
    std::map<std::string, msg::PoseCorrections> out;
    std::map<std::string, const Node*> newest;
    for (const Node& n : nodes) {
      if (!n.valid || n.kf.session != registry.currentSession(n.kf.robot_id)) continue;
      msg::PoseCorrections& c = out[n.kf.robot_id];
      c.robot_id = n.kf.robot_id;
      c.graph_revision = counters.graph_revision;
      c.keyframes.push_back({n.kf.keyframe_id, n.kf.T_map_kf});
      newest[n.kf.robot_id] = &n;
    }
    for (auto& [robot, c] : out) {
      const Node& n = *newest[robot];
      c.T_map_odom = se3::normalized(n.kf.T_map_kf * n.kf.T_odom_kf.inverse());
      if (c.keyframes.size() > static_cast<size_t>(msg::kMaxCorrections))
        c.keyframes.erase(c.keyframes.begin(), c.keyframes.end() - msg::kMaxCorrections);
    }
    std::vector<MapNodePose> map_poses;
    if (map_worker) {
      map_poses.reserve(nodes.size());
      for (const Node& n : nodes)
        if (n.valid) map_poses.push_back({n.kf.node_id, n.kf.map_id, n.kf.T_map_kf});
    }
    lock.unlock();
    if (map_worker) map_worker->updatePoses(std::move(map_poses));
    for (const auto& [robot, c] : out) {
      log::debug("server: corrections to ", robot, ": ", c.keyframes.size(), " keyframes");
      publishTo(robot, c);
    }
  }

  // ---- status thread ---------------------------------------------------------------------------------
  void runStatus() {
    std::unique_lock<std::mutex> lock(status_mutex);
    for (;;) {
      status_cv.wait_for(lock, std::chrono::duration<double>(config.status_period_s));
      {
        std::lock_guard<std::mutex> q(queue_mutex);
        if (stopping) return;
      }
      publishStatus();
    }
  }

  void publishStatus() {
    msg::ServerStatus status;
    std::vector<std::string> robots;
    {
      std::lock_guard<std::mutex> lock(state_mutex);
      status.uptime_s = std::chrono::duration<double>(Clock::now() - started).count();
      status.graph_revision = counters.graph_revision;
      for (const ServerRobotStats& r : registry.stats()) {
        msg::RobotStatus s;
        s.robot_id = r.robot_id;
        s.keyframes = r.keyframes;
        s.loop_closures = r.loops;
        s.rejected_messages = static_cast<int64_t>(r.keyframes_refused);
        s.last_utime = r.last_utime;
        status.robots.push_back(s);
        robots.push_back(r.robot_id);
      }
    }
    status.state = "running";
    for (const std::string& robot : robots) publishTo(robot, status);
  }

  // ---- start / restore ---------------------------------------------------------------------------------
  /// Starts the map worker and hands it the restored keyframes (their images are read from the store on
  /// the map worker, in the background).
  void startMapWorker() {
    MapWorkerPublishers publishers;
    publishers.slice = [this](const std::string& robot, const msg::OccupancySlice& slice) {
      publishTo(robot, slice);
    };
    publishers.map = [this](const std::string& robot, const msg::MapUpdate& update) {
      publishTo(robot, update);
    };
    map_worker = std::make_unique<MapWorker>(config, *store, std::move(publishers));
    std::lock_guard<std::mutex> lock(state_mutex);
    for (const Node& n : nodes) {
      const auto camera = n.valid ? registry.camera(n.kf.robot_id) : std::nullopt;
      if (!camera) continue;
      map_worker->addKeyframe(
          {n.kf.node_id, n.kf.robot_id, n.kf.map_id, n.kf.T_map_kf, *camera, {}, {}, false});
    }
    map_worker->start();
  }

  Status restore() {
    const auto loaded = registry.load(store->directory());
    if (!loaded) return Status::failure(loaded.error());
    for (const ServerRobotStats& r : registry.stats())
      if (r.camera) detector.setRobotCamera(registry.index(r.robot_id), *r.camera);
    int skipped = 0;
    for (const StoredKeyframe& stored : store->keyframes()) {
      const auto camera = registry.camera(stored.keyframe.robot_id);
      const auto features =
          camera ? featuresFromMessage(stored.keyframe, PinholeCamera(*camera))
                 : Result<FrameFeatures>::failure("no camera for robot " + stored.keyframe.robot_id);
      if (!features || stored.node_id < static_cast<int64_t>(nodes.size())) {
        ++skipped;
        log::error("server: stored keyframe ", stored.node_id,
                   " skipped: ", features ? "node id out of order" : features.error());
        continue;
      }
      integrate(stored, *features, false, nullptr);
      registry.countKeyframe(stored.keyframe.robot_id);
      ++counters.keyframes;
    }
    for (const StoredLoop& loop : store->loops()) {
      if (loop.from_node < 0 || loop.to_node < 0 || loop.from_node >= static_cast<int64_t>(nodes.size()) ||
          loop.to_node >= static_cast<int64_t>(nodes.size()) ||
          !nodes[static_cast<size_t>(loop.from_node)].valid ||
          !nodes[static_cast<size_t>(loop.to_node)].valid) {
        log::error("server: stored loop ", loop.from_node, "-", loop.to_node, " names unknown keyframes");
        continue;
      }
      LoopEdge edge;
      edge.from_id = static_cast<int>(loop.from_node);
      edge.to_id = static_cast<int>(loop.to_node);
      edge.T_from_to = loop.T_from_to;
      edge.information = loop.information;
      edge.inliers = loop.inliers;
      edge.motion_measure = loop.motion_measure;
      if (const Status s = addLoopEdge(edge); !s) {
        log::error("server: stored loop: ", s.error());
        continue;
      }
      detector.restoreEdge(edge);
      registry.countLoop(nodes[static_cast<size_t>(edge.from_id)].kf.robot_id);
      ++counters.loops_accepted;
      ++counters.restored_loops;
    }
    counters.restored_keyframes = counters.keyframes;
    refreshComponents();
    if (counters.keyframes > 0)
      log::info("server: restored ", counters.keyframes, " keyframes, ", counters.restored_loops,
                " loops from ", store->directory(),
                skipped ? " (" + std::to_string(skipped) + " skipped)" : std::string());
    return Status::success();
  }
};

// ---------------------------------------------------------------------------------------------------------

MapServer::MapServer(MapServerConfig config, transport::Transport& transport, msg::KeyStore keys)
    : impl_(std::make_unique<Impl>(std::move(config), transport, std::move(keys))) {}

MapServer::~MapServer() { stop(); }

Status MapServer::start() {
  Impl& m = *impl_;
  if (m.started_threads) return Status::failure("server already started");
  if (const std::string problems = m.config.validate(); !problems.empty())
    return Status::failure("server configuration: " + problems);
  MapStoreOptions store_options;
  store_options.sync = m.config.store_sync;
  auto store = MapStore::open(m.config.map_dir, store_options);
  if (!store) return Status::failure(store.error());
  m.store = std::move(*store);
  {
    std::lock_guard<std::mutex> lock(m.state_mutex);
    m.counters.recovery = m.store->recovery();
    if (const Status s = m.restore(); !s) return s;
  }
  if (m.config.occupancy_enabled) m.startMapWorker();
  m.optimizer = std::make_unique<PoseGraphOptimizer>(
      m.config.graph, [&m](const std::shared_ptr<const OptimizedPoses>& result) {
        Impl::Event e;
        e.kind = Impl::Event::Kind::kOptimized;
        e.result = result;
        m.push(std::move(e), false);
      });
  m.worker = std::thread([&m] { m.run(); });
  if (m.config.status_period_s > 0.0) m.status_thread = std::thread([&m] { m.runStatus(); });
  m.started_threads = true;
  if (m.counters.restored_loops > 0) m.submitOptimization();

  {
    std::lock_guard<std::mutex> lock(m.gate->mutex);
    m.gate->impl = &m;
  }
  std::weak_ptr<Impl::Gate> weak = m.gate;
  auto handler = [weak](const std::string& channel, const uint8_t* data, size_t size) {
    const auto gate = weak.lock();
    if (!gate) return;
    std::lock_guard<std::mutex> lock(gate->mutex);
    if (gate->impl) gate->impl->onMessage(channel, data, size);
  };
  std::vector<std::string> patterns;
  if (m.config.robots.empty()) {
    patterns.push_back("rgbdmap/*");
  } else {
    for (const std::string& robot : m.config.robots)
      for (const auto type :
           {msg::MessageType::kHello, msg::MessageType::kHeartbeat, msg::MessageType::kKeyframe})
        patterns.push_back(*msg::channelFor(type, robot));
  }
  for (const std::string& p : patterns)
    if (const Status s = m.transport.subscribe(p, handler); !s)
      return Status::failure("subscribe " + p + ": " + s.error() +
                             (m.config.robots.empty() ? " (list the robots in the configuration)" : ""));
  log::info("server: serving ",
            m.config.robots.empty() ? std::string("any robot")
                                    : std::to_string(m.config.robots.size()) + " robot(s)",
            " from ", m.config.map_dir);
  return Status::success();
}

void MapServer::stop() {
  Impl& m = *impl_;
  {
    std::lock_guard<std::mutex> lock(m.gate->mutex);
    m.gate->impl = nullptr;
  }
  if (m.optimizer) m.optimizer->stop();
  {
    std::lock_guard<std::mutex> lock(m.queue_mutex);
    m.stopping = true;
  }
  m.queue_cv.notify_all();
  m.idle_cv.notify_all();
  m.status_cv.notify_all();
  if (m.worker.joinable()) m.worker.join();
  if (m.status_thread.joinable()) m.status_thread.join();
  if (m.map_worker) m.map_worker->stop();
}

bool MapServer::waitIdle(double timeout_s) {
  Impl& m = *impl_;
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  {
    std::unique_lock<std::mutex> lock(m.queue_mutex);
    const bool idle = m.idle_cv.wait_until(lock, deadline, [&] {
      return m.stopping || (m.queue.empty() && !m.busy && m.applied_revision >= m.submitted_revision);
    });
    if (!idle || m.stopping) return false;
  }
  if (!m.map_worker) return true;
  return m.map_worker->waitIdle(
      std::max(0.0, std::chrono::duration<double>(deadline - Clock::now()).count()));
}

MapServerStats MapServer::stats() const {
  const Impl& m = *impl_;
  std::unique_lock<std::mutex> lock(m.state_mutex);
  MapServerStats s = m.counters;
  s.messages_rejected = m.rejects.total();
  s.keyframes_dropped_queue_full = m.dropped_queue_full.load();
  s.unknown_robot_messages = m.unknown_robot.load();
  s.ingest_ms_median = quantile(m.ingest_ms, 0.5);
  s.ingest_ms_p90 = quantile(m.ingest_ms, 0.9);
  s.ingest_cpu_ms_median = quantile(m.ingest_cpu_ms, 0.5);
  s.ingest_cpu_ms_p90 = quantile(m.ingest_cpu_ms, 0.9);
  s.verify_ms_median = quantile(m.verify_ms, 0.5);
  s.decode_ms_median = quantile(m.stage_ms[0], 0.5);
  s.store_ms_median = quantile(m.stage_ms[1], 0.5);
  s.loops_ms_median = quantile(m.stage_ms[2], 0.5);
  s.ingest_ms_max = m.ingest_ms.empty() ? 0.0 : *std::max_element(m.ingest_ms.begin(), m.ingest_ms.end());
  s.maps = static_cast<int>(m.components.size());
  s.robots = m.registry.stats();
  for (ServerRobotStats& r : s.robots) {
    const int index = m.registry.index(r.robot_id);
    for (const Impl::Chain& c : m.chains) r.chains += c.robot == index;
    const Impl::Node* newest = nullptr;
    for (const Impl::Node& n : m.nodes)
      if (n.kf.robot_id == r.robot_id) newest = &n;
    if (!newest) continue;
    r.map_id = newest->kf.map_id;
    for (const Impl::Node& n : m.nodes)
      if (n.kf.map_id == r.map_id && n.kf.robot_id != r.robot_id) r.merged = true;
  }
  lock.unlock();
  // Outside the server's state lock: counting the octree's leaves must not hold up the ingest worker.
  if (m.map_worker) m.map_worker->fillStats(&s);
  return s;
}

std::vector<ServerKeyframe> MapServer::keyframes() const {
  const Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.state_mutex);
  std::vector<ServerKeyframe> out;
  out.reserve(m.nodes.size());
  for (const Impl::Node& n : m.nodes)
    if (n.valid) out.push_back(n.kf);
  return out;
}

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

std::vector<double> MapServer::ingestTimesMs() const {
  const Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.state_mutex);
  return m.ingest_ms;
}

}  // namespace rgbdmap
