#pragma once
// The ingest pipeline: the coordinator of the ingest side. It owns the state lock and wires the parts, and
// runs on the ingest worker, one event at a time (prepare() is the exception: IngestQueue's decode thread
// decodes the next keyframes with it while the ingest worker integrates this one):
//   Hello -> session; Keyframe -> image headers against the robot's camera (image_admission.hpp) ->
//   decode + validate images (KeyframeDecoder) -> store durably -> acknowledge -> deferred
//   (KeyframeIntake): placeDeferred(), a later event of the same worker -> in chain order (ChainOrder) ->
//   loop detection -> pose graph (MapGraph; -> a batch to the optimiser when loops were added);
//   optimisation result -> apply -> PoseCorrections to every robot; a periodic tick gives up on
//   predecessors that do not come and follows the robots' heartbeats (CorrectionsFollower).
// Restoring from the map store: MapRestore. Readers (stats, keyframes) take the same state lock from other
// threads; prepare() and the feature loader do not.
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "rgbdmap/backend/optimizer_batch.hpp"
#include "rgbdmap/ingest/chain_order.hpp"
#include "rgbdmap/ingest/corrections_follower.hpp"
#include "rgbdmap/ingest/feature_loader.hpp"
#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/ingest/ingest_timings.hpp"
#include "rgbdmap/ingest/keyframe_decoder.hpp"
#include "rgbdmap/ingest/keyframe_intake.hpp"
#include "rgbdmap/ingest/localize_sessions.hpp"
#include "rgbdmap/ingest/map_graph.hpp"
#include "rgbdmap/intake/hello_hold.hpp"
#include "rgbdmap/intake/robot_registry.hpp"
#include "rgbdmap/model/map_server_config.hpp"
#include "rgbdmap/model/server_keyframe.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/vision/feature_cache.hpp"
#include "rgbdmap/workers/map_worker.hpp"
#include "rgbdmap/workers/robot_publisher.hpp"

namespace rgbdmap {

class IngestPipeline {
 public:
  using Decoded = DecodedKeyframe;
  using Prepared = PreparedKeyframe;
  using SubmitGraph = MapGraph::SubmitGraph;
  static constexpr size_t kDeferredMax = KeyframeIntake::kDeferredMax;

  /// References must outlive the pipeline. revision_base: added to the optimiser's revisions.
  IngestPipeline(const MapServerConfig& config, RobotRegistry& registry, RobotPublisher& publisher,
                 int64_t revision_base);

  /// Before restore(): the opened store and where graph batches go.
  void attach(MapStore* store, SubmitGraph submit);
  /// Told of every KeyframeAck as it is sent (stored, refused, or seen before): the receive side repeats it
  /// for a robot that shows it did not get it (Inbox::noteAnswer). Set before the ingest worker starts.
  using AnswerSink = std::function<void(const std::string& robot, int64_t session, int keyframe_id,
                                        bool accepted, const std::string& reason)>;
  void setAnswerSink(AnswerSink sink) { answered_ = std::move(sink); }
  /// Restores robots, keyframes and loop edges from the store (MapRestore).
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
  /// Stored and acknowledged keyframes whose placement has not run yet (any thread).
  size_t deferred() const { return intake_.deferred(); }
  /// Placements deferred since the last call (the worker posts one event for each).
  size_t takeNewlyDeferred();
  void onOptimized(const MapOptimization& result);
  /// Gives up on late predecessors and follows the robots' heartbeats with corrections.
  void onTick();
  /// After the ingest worker stopped: every keyframe still waiting for its predecessor into the graph (new
  /// chains placed by odometry, no loop detection), so that the final outputs list every stored keyframe.
  void onStop();

  // ---- the decode thread (without the state lock)
  Prepared prepare(msg::Keyframe keyframe) { return decoder_.prepare(std::move(keyframe)); }

  // ---- readers (any thread)
  /// Counters, timings, maps and robots (not the receive-side or map worker fields).
  IngestReport stats() const;
  std::vector<ServerKeyframe> keyframes() const;
  std::vector<ServerLoop> loops() const;
  std::vector<double> ingestTimesMs() const;
  int64_t graphRevision() const;
  /// Per robot that said Hello: its pose is in the map (ServerRobotStats::placed), for the status thread.
  std::map<std::string, bool> placedRobots() const;

 private:
  using Lock = std::unique_lock<std::mutex>;

  /// robot's map, chains and `placed` (main_map: the map of the graph's first keyframe).
  void fillPlacementLocked(ServerRobotStats* robot, int main_map,
                           const std::map<std::string, LocalizeRobotStats>& localizing) const;
  int mainMapLocked() const;

  /// False for a keyframe seen before (stored, deferred, waiting in the chain order or refused): answered
  /// again.
  bool admitLocked(const msg::Keyframe& kf, const KeyframeKey& key, Lock& lock);
  void refuseLocked(const msg::Keyframe& kf, const KeyframeKey& key, const std::string& reason, Lock& lock);
  /// The KeyframeAck of `kf` to its robot, and to answered_.
  void answer(const msg::Keyframe& kf, bool accepted, const std::string& reason);
  /// When the ingest worker took a keyframe (wall, its CPU time).
  struct Started {
    std::chrono::steady_clock::time_point t0;
    double cpu0 = 0.0;
  };
  /// A keyframe of a robot that localises (ingest_localize.cpp): decoded, matched against the map, judged
  /// by the placement rules, acknowledged and answered with corrections; never stored.
  void localizeLocked(Prepared prepared, const CameraIntrinsics& camera, int robot, Lock& lock);
  /// Stores and acknowledges a decoded keyframe, then defers its placement.
  void storeLocked(const msg::Keyframe& kf, const KeyframeKey& key, WaitingKeyframe waiting,
                   DecodedKeyframe decoded, KeyframeTiming timing, Started started);
  /// ChainOrder's Integrate: a live keyframe with loop detection and the map worker, or a restored one.
  void integrateLocked(const WaitingKeyframe& waiting, const DecodedImages* images, bool live);
  void addLiveLocked(const StoredKeyframe& stored, const FrameFeatures& features,
                     const DecodedImages* images);
  void countLoopStatsLocked(const LoopStats& loop_stats);

  const MapServerConfig& config_;
  RobotRegistry& registry_;
  RobotPublisher& publisher_;
  AnswerSink answered_;
  MapStore* store_ = nullptr;
  MapWorker* map_worker_ = nullptr;  ///< null when occupancy is off
  uint64_t map_pose_epoch_ = 0;      ///< pose updates sent to map_worker_ (MapKeyframeJob::pose_epoch)
  FeatureLoader loader_;             ///< not under mutex_: the cache loads from any thread
  /// The features of every keyframe, shared by the loop detector and the optimiser's landmark map; the
  /// newest used (features_in_memory) in RAM, the others read back from the store (loader_).
  std::shared_ptr<FeatureCache> features_;
  KeyframeDecoder decoder_;  ///< prepare() and its seen-set are not under mutex_

  mutable std::mutex mutex_;  ///< the state lock: everything below
  IngestStats stats_;         ///< the counting fields; the derived ones are filled in stats()
  MapGraph graph_;
  ChainOrder order_;
  KeyframeIntake intake_;
  CorrectionsFollower corrections_;
  HelloHold hello_hold_;  ///< keyframes that came before their robot's Hello
  LocalizeSessions localize_;
  int localize_queries_ = 0;       ///< negative query ids for LoopDetector::place
  int64_t localize_revision_ = 0;  ///< graph_revision of localising robots' corrections
  IngestTimings timings_;
};

}  // namespace rgbdmap
