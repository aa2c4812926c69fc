#pragma once
// The ingest pipeline owns the map state (keyframe index, pose graph, loop detector, counters) and runs on
// the ingest worker, one event at a time (prepare() is the exception: IngestQueue's decode thread decodes
// the next keyframes with it while the ingest worker integrates this one):
//   Hello -> session; Keyframe -> image headers against the robot's camera (image_admission.hpp) ->
//   decode + validate images -> store durably -> acknowledge -> deferred: placeDeferred(), a later event
//   of the same worker -> (in chain order, through the reorder buffer) loop detection -> pose graph (-> a
//   snapshot to the optimiser when loops were added);
//   optimisation result -> apply -> PoseCorrections to every robot; a periodic tick gives up on
//   predecessors that do not come.
// Readers (stats, keyframes) take the same state lock from other threads. Restoring from the map store is
// in map_restore.cpp, graph insertion and optimisation results in ingest_graph.cpp, chain order (reorder
// buffer, chain splits) in ingest_order.cpp.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "rgbdmap/intake/hello_hold.hpp"
#include "ingest_timings.hpp"
#include "keyframe_index.hpp"
#include "map_worker.hpp"
#include "reorder_buffer.hpp"
#include "rgbdmap/backend/optimizer_batch.hpp"
#include "rgbdmap/graph/pose_graph.hpp"
#include "rgbdmap/graph/pose_graph_optimizer.hpp"
#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/vision/features.hpp"
#include "robot_publisher.hpp"
#include "rgbdmap/intake/robot_registry.hpp"

namespace rgbdmap {

class IngestPipeline {
 public:
  /// A keyframe's decoded images and features.
  struct Decoded {
    DecodedImages images;
    FrameFeatures features;
  };
  /// A keyframe as the decode thread left it: decoded for `camera`, or not (`decoded` empty: no camera yet,
  /// seen before, or refused before decoding) and then onKeyframe() does it all as before.
  struct Prepared {
    msg::Keyframe keyframe;
    std::optional<CameraIntrinsics> camera;  ///< what it was decoded for (a Hello may change it meanwhile)
    std::optional<Result<Decoded>> decoded;
    double decode_ms = 0.0;      ///< wall
    double decode_cpu_ms = 0.0;  ///< the decode thread's CPU time
  };

  /// Hands what was added to the graph since the last call to the optimiser (called with the state lock
  /// held, so keep it short).
  using SubmitGraph = std::function<void(OptimizerBatch batch)>;

  /// References must outlive the pipeline. revision_base: added to the optimiser's revisions.
  IngestPipeline(const MapServerConfig& config, RobotRegistry& registry, RobotPublisher& publisher,
                 int64_t revision_base);

  /// Before restore(): the opened store and where graph snapshots go.
  void attach(MapStore* store, SubmitGraph submit);
  /// Restores robots, keyframes and loop edges from the store (map_restore.cpp).
  Status restore();
  /// Hands every restored keyframe to the map worker (it reads the images back itself) and keeps it for
  /// live keyframes and pose updates.
  void startFeeding(MapWorker* map_worker);
  /// After restore(): a first optimisation when loops were restored.
  void submitRestoredLoops();
  /// The keyframes' features (for the optimiser's landmark map: MapOptimizerConfig::features).
  const std::shared_ptr<FeatureCache>& featureCache() const { return features_; }

  // ---- the ingest worker
  void onHello(const msg::Hello& hello);
  void onKeyframe(const msg::Keyframe& keyframe);
  /// A keyframe prepare()d on the decode thread; its decoding is used when it was for the current camera.
  /// Stored and acknowledged here; its loop detection and graph insertion wait as a deferred placement.
  void onKeyframe(Prepared prepared);
  /// The oldest deferred keyframe into the graph (loop detection, pose graph, map worker); false when none.
  /// The ingest worker serves new keyframes (store, acknowledgement) before these, so that a robot's
  /// acknowledgement waits for at most the one placement in progress, not for the loop detection of every
  /// keyframe queued ahead of it (IngestQueue).
  bool placeDeferred();
  /// Stored and acknowledged keyframes whose placement has not run yet.
  size_t deferred() const;
  /// At most this many wait for placement: beyond, the worker places before it stores more (the robots'
  /// queues fill and they resend: the acknowledgements then follow the loop detection's pace again). At
  /// 16 keyframes/s, 256 is 16 s of the loop detection falling behind; each holds its features (~70 KB)
  /// and, the newest kDeferredWithImages only, its decoded images (~1.5 MB at 640x480; the others' images
  /// the map worker reads back from the store).
  static constexpr size_t kDeferredMax = 256;
  static constexpr size_t kDeferredWithImages = 8;
  /// Placements deferred since the last call (the worker posts one event for each).
  size_t takeNewlyDeferred();

  // ---- the decode thread (one thread: its feature extractor is its own)
  /// Decodes the images and the features (extracted when sent without) outside the state lock, so that the
  /// ingest worker only stores and integrates. Not decoded: a keyframe of a robot without a camera yet, one
  /// seen before (a resend), or one whose image headers the camera refuses (onKeyframe refuses it).
  Prepared prepare(msg::Keyframe keyframe);
  void onOptimized(const MapOptimization& result);
  /// Gives up on late predecessors and follows the robots' heartbeats with corrections
  /// (ingest_corrections.cpp).
  void onTick();
  /// After the ingest worker stopped: every keyframe still waiting for its predecessor into the graph (new
  /// chains placed by odometry, no loop detection), so that the final outputs list every stored keyframe.
  void onStop();

  // ---- readers (any thread)
  /// Counters, timings, maps and robots (not the receive-side or map worker fields).
  MapServerStats stats() const;
  std::vector<ServerKeyframe> keyframes() const;
  std::vector<ServerLoop> loops() const;
  std::vector<double> ingestTimesMs() const;
  int64_t graphRevision() const;

 private:
  using Lock = std::unique_lock<std::mutex>;

  // ingest_pipeline.cpp: the keyframe path
  bool admitLocked(const msg::Keyframe& kf, const KeyframeKey& key, Lock& lock);
  void refuseLocked(const msg::Keyframe& kf, const KeyframeKey& key, const std::string& reason, Lock& lock);
  /// Decodes the images (their headers were checked against the camera: image_admission.hpp) and features.
  /// Images, and the features: as sent, or extracted from the colour when sent without (caller holds
  /// mutex_: the extractor is not thread-safe).
  Result<Decoded> decodeLocked(const msg::Keyframe& kf, const CameraIntrinsics& camera);
  static Result<Decoded> decode(OrbExtractor& extractor, const msg::Keyframe& kf,
                                const CameraIntrinsics& camera);
  /// Keys stored or refused, for prepare() without the state lock (a resend is not decoded again).
  void noteSeen(const KeyframeKey& key);
  bool seen(const KeyframeKey& key) const;
  /// False while the store takes no appends (failed; StoreRetry recovers it) or robots.txt could not be
  /// saved: the keyframe is left unacknowledged (counted), so its robot sends it again later.
  bool storeWritableLocked();
  /// Graph, loop detection, map worker (`images`, or read back from the store when null), loop edges,
  /// optimisation.
  void addLiveLocked(const StoredKeyframe& stored, const FrameFeatures& features,
                     const DecodedImages* images);
  int addDetectedLoopsLocked(const std::vector<LoopEdge>& edges, int robot);
  /// Hands batch_ to the optimiser; `solve`: loop edges were added or chains joined; `must_solve`: chains
  /// joined or a restore (a solve whatever the loops' consistency; merging loops set batch_.must_solve).
  void submitOptimizationLocked(bool solve = false, bool must_solve = false);

  // ingest_order.cpp: chain order
  /// A stored keyframe into the graph now (its predecessor is there, refused, or it has none), followed by
  /// the keyframes that waited for it; or into the reorder buffer. `live`: received now (loop detection,
  /// map worker, counted as out of order when it waits) or restored.
  void placeLocked(WaitingKeyframe waiting, const DecodedImages* images, bool live);
  void integrateWithSuccessorsLocked(WaitingKeyframe first, const DecodedImages* images, bool live);
  /// Runs given up on (timeout_s, reorder_capacity) start new chains.
  void giveUpWaitingLocked(std::chrono::steady_clock::time_point now, double timeout_s, bool live);
  KeyframeKey keyOf(const StoredKeyframe& stored) const;
  std::optional<KeyframeKey> predecessorOf(const StoredKeyframe& stored) const;
  /// A keyframe integrated without its predecessor: the split is counted and remembered, so that the
  /// predecessor joins it with its odometry edge if it comes after all.
  void noteSplitLocked(const IndexedNode& node, const msg::Keyframe& kf);
  /// The odometry edge from a keyframe split off earlier to `node`, its late predecessor, if there is one.
  void joinSplitSuccessorLocked(const IndexedNode& node);

  // ingest_graph.cpp: the graph
  /// Adds a stored keyframe to the index, the graph and the detector. `detect`: run loop detection (a live
  /// keyframe) or just index it (restore). Returns the accepted loop edges.
  std::vector<LoopEdge> integrateLocked(const StoredKeyframe& stored, const FrameFeatures& features,
                                        bool detect, LoopStats* loop_stats);
  /// `prev`: the predecessor's node; `split`: it has one that is not in the graph (a new chain, placed by
  /// the odometry of its segment's latest keyframe in the graph).
  IndexedNode makeNodeLocked(const StoredKeyframe& stored, int robot, std::optional<int64_t> prev,
                             bool split);
  void addToGraphLocked(const IndexedNode& node, const msg::Keyframe& kf, std::optional<int64_t> prev);
  void addOdometryEdgeLocked(int64_t from, int64_t to, const SE3& T_prev_cur, const Mat6& information);
  Status addLoopEdgeLocked(const LoopEdge& edge);
  void applyOptimizedLocked(const MapOptimization& result);
  /// The keyframe's features and camera for bundle adjustment, into batch_.
  void addToBatchLocked(const IndexedNode& node, const std::shared_ptr<const FrameFeatures>& features);
  std::map<std::string, int64_t> currentSessionsLocked() const;
  std::vector<MapNodePose> mapPosesLocked() const;

  // ingest_corrections.cpp: corrections that follow the robots' heartbeats
  using Published = std::vector<std::pair<std::string, msg::PoseCorrections>>;
  /// Remembers what an optimisation told each robot (the first send of it).
  void noteCorrectionsLocked(const std::map<std::string, msg::PoseCorrections>& corrections,
                             std::chrono::steady_clock::time_point now);
  /// For each robot whose heartbeat names a keyframe in the graph: the newest corrections again when they
  /// cover it and may have been lost, or an optimisation when none covers it yet (no loop came after it).
  Published followHeartbeatsLocked(std::chrono::steady_clock::time_point now);

  /// The cache's loader: the stored record read back, its features rebuilt with the robot's camera.
  /// Called from the ingest or the optimiser thread without mutex_.
  Result<FrameFeatures> loadFeatures(int64_t node_id) const;
  void setLoaderCamera(const std::string& robot_id, const CameraIntrinsics& camera);
  // map_restore.cpp
  int restoreKeyframesLocked();  ///< returns the number skipped; keyframes may be stored out of chain order
  void restoreLoopsLocked();

  const MapServerConfig& config_;
  RobotRegistry& registry_;
  RobotPublisher& publisher_;
  const int64_t revision_base_;  ///< graph revisions grow across restarts: start second * 1e6 + solve number
  MapStore* store_ = nullptr;
  SubmitGraph submit_;
  MapWorker* map_worker_ = nullptr;  ///< null when occupancy is off
  uint64_t map_pose_epoch_ = 0;      ///< pose updates sent to map_worker_ (MapKeyframeJob::pose_epoch)
  /// The features of every keyframe, shared by the loop detector and the optimiser's landmark map; the
  /// newest used (features_in_memory) in RAM, the others read back from the store (loadFeatures).
  std::shared_ptr<FeatureCache> features_;
  mutable std::mutex loader_mutex_;                         ///< loader_cameras_ (not under mutex_)
  std::map<std::string, CameraIntrinsics> loader_cameras_;  ///< the robots' cameras, for loadFeatures

  mutable std::mutex mutex_;  ///< everything below
  KeyframeIndex index_;
  PoseGraph graph_;       ///< structure and current poses; the optimiser solves its own copy, fed by batch_
  OptimizerBatch batch_;  ///< additions since the last submit
  LoopDetector detector_;
  int64_t next_edge_id_ = 0;
  int64_t next_node_id_ = 0;  ///< of the next stored keyframe (node ids are dense in store order)
  ReorderBuffer reorder_;
  /// Stored and acknowledged, waiting for placeDeferred() (in store order).
  struct Deferred {
    WaitingKeyframe waiting;
    KeyframeKey key;
    std::optional<DecodedImages> images;  ///< dropped beyond kDeferredWithImages (read back instead)
    KeyframeTiming timing;                ///< of the store part (total_ms, cpu_ms: so far)
  };
  std::deque<Deferred> deferred_;          ///< at most kDeferredMax: admitLocked scans it for resends
  std::atomic<size_t> deferred_count_{0};  ///< deferred_.size(), read by deferred() without mutex_
  size_t newly_deferred_ = 0;
  HelloHold hello_hold_;  ///< keyframes that came before their robot's Hello
  struct SplitHead {
    int64_t node_id = 0;
    SE3 T_prev_cur = SE3::Identity();
    Mat6 information = Mat6::Identity();
  };
  std::map<KeyframeKey, SplitHead> split_heads_;  ///< by the key of the predecessor that did not come
  bool graph_joined_ = false;                     ///< a late predecessor joined a split chain: optimise
  struct CorrectionsSent {
    msg::PoseCorrections last;  ///< the newest sent to the robot
    int64_t robot_session = 0;  ///< the robot's process they were built for
    int sends = 0;              ///< how often `last` went out
    std::chrono::steady_clock::time_point sent_at;
    std::optional<KeyframeKey> optimised_for;  ///< the heartbeat keyframe an optimisation was asked for
  };
  std::map<std::string, CorrectionsSent> corrections_sent_;
  MapServerStats counters_;        ///< the counting fields; the derived ones are filled in stats()
  OrbExtractor extractor_;         ///< config_.features, for keyframes sent without features
  OrbExtractor decode_extractor_;  ///< the same, for prepare() (the decode thread only)
  mutable std::mutex seen_mutex_;  ///< seen_ (not under mutex_: prepare() must not wait for an ingest)
  std::set<KeyframeKey> seen_;     ///< stored or refused (a few bytes per keyframe)
  std::atomic<uint64_t> decoded_ahead_{0};  ///< keyframes prepare() decoded
  IngestTimings timings_;
  // A failed store (a full disk): what waits for it to work again.
  bool registry_unsaved_ = false;          ///< robots.txt not written since a robot (camera) changed
  bool store_down_logged_ = false;         ///< one log line per outage
  std::vector<StoredLoop> loops_unsaved_;  ///< in the graph, not stored yet: stored with the next loops
};

}  // namespace rgbdmap
