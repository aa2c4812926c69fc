// The ingest pipeline's chain order: "store first, order later". A stored and acknowledged keyframe enters
// the graph once its odometry predecessor is there; until then it waits in the reorder buffer. A
// predecessor that does not come (robot died, retransmissions given up, reorder bound or timeout) or was
// refused: the waiting keyframes start a new chain, placed by the odometry of their segment and re-anchored
// by loop closure as a restarted robot's chain is. If the predecessor comes after all, its odometry edge
// joins the two chains.
#include <utility>

#include "ingest_pipeline.hpp"
#include "rgbdmap/backend/edge_information.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

KeyframeKey IngestPipeline::keyOf(const StoredKeyframe& stored) const {
  const msg::Keyframe& kf = stored.keyframe;
  return {registry_.index(kf.robot_id), stored.session, kf.segment_id, kf.keyframe_id};
}

std::optional<KeyframeKey> IngestPipeline::predecessorOf(const StoredKeyframe& stored) const {
  const msg::Keyframe& kf = stored.keyframe;
  if (kf.previous_keyframe_id < 0) return std::nullopt;
  return KeyframeKey{registry_.index(kf.robot_id), stored.session, kf.segment_id, kf.previous_keyframe_id};
}

void IngestPipeline::placeLocked(WaitingKeyframe waiting, const DecodedImages* images, bool live) {
  const std::optional<KeyframeKey> prev = predecessorOf(waiting.stored);
  if (prev && !index_.contains(*prev) && !index_.refused(*prev)) {
    if (live) {
      registry_.recordKeyframe(waiting.stored.keyframe.robot_id, RobotRegistry::KeyframeOutcome::kOutOfOrder);
      log::debug("server: keyframe ", waiting.stored.keyframe.keyframe_id, " of ",
                 waiting.stored.keyframe.robot_id, " stored, waits for its predecessor ",
                 waiting.stored.keyframe.previous_keyframe_id);
    }
    const KeyframeKey key = keyOf(waiting.stored);  // before the move into the by-value argument
    reorder_.add(key, *prev, std::move(waiting));
    return;
  }
  integrateWithSuccessorsLocked(std::move(waiting), images, live);
}

void IngestPipeline::integrateWithSuccessorsLocked(WaitingKeyframe first, const DecodedImages* images,
                                                   bool live) {
  std::vector<WaitingKeyframe> ready;
  ready.push_back(std::move(first));
  for (size_t i = 0; i < ready.size(); ++i) {
    const KeyframeKey key = keyOf(ready[i].stored);
    if (live) {
      addLiveLocked(ready[i].stored, ready[i].features, i == 0 ? images : nullptr);
    } else {
      integrateLocked(ready[i].stored, ready[i].features, false, nullptr);
      registry_.recordKeyframe(ready[i].stored.keyframe.robot_id, RobotRegistry::KeyframeOutcome::kPlaced);
      ++counters_.keyframes;
    }
    for (WaitingKeyframe& next : reorder_.takeSuccessors(key)) ready.push_back(std::move(next));
  }
}

void IngestPipeline::giveUpWaitingLocked(std::chrono::steady_clock::time_point now, double timeout_s,
                                         bool live) {
  while (std::optional<WaitingKeyframe> head =
             reorder_.takeRunToGiveUp(now, timeout_s, config_.reorder_capacity))
    integrateWithSuccessorsLocked(std::move(*head), nullptr, live);
}

void IngestPipeline::onStop() {
  Lock lock(mutex_);
  if (!deferred_.empty()) {
    log::info("server: stopping with ", deferred_.size(), " stored keyframe(s) not placed yet: ",
              "into the graph by odometry, without loop detection, for the final outputs");
    for (Deferred& d : deferred_) placeLocked(std::move(d.waiting), nullptr, false);
    deferred_.clear();
    deferred_count_.store(0, std::memory_order_relaxed);
  }
  const size_t waiting = reorder_.size();
  if (waiting == 0) return;
  log::info("server: stopping with ", waiting, " stored keyframe(s) still waiting for a predecessor: ",
            "placed by odometry in new chains for the final outputs");
  giveUpWaitingLocked(std::chrono::steady_clock::time_point::max(), 0.0, false);
}

void IngestPipeline::noteSplitLocked(const IndexedNode& node, const msg::Keyframe& kf) {
  const KeyframeKey missing{node.robot, node.kf.session, node.kf.segment, kf.previous_keyframe_id};
  const bool refused = index_.refused(missing);
  registry_.recordKeyframe(kf.robot_id, RobotRegistry::KeyframeOutcome::kChainSplit);
  log::info("server: keyframe ", kf.keyframe_id, " of ", kf.robot_id, " starts a new chain: its predecessor ",
            kf.previous_keyframe_id, refused ? " was refused" : " did not come");
  if (!refused)
    split_heads_[missing] = {node.kf.node_id, kf.T_prev_cur,
                             odometryInformation(kf.information, config_.edgeInformation())};
}

void IngestPipeline::joinSplitSuccessorLocked(const IndexedNode& node) {
  const auto it = split_heads_.find({node.robot, node.kf.session, node.kf.segment, node.kf.keyframe_id});
  if (it == split_heads_.end()) return;
  const SplitHead head = it->second;
  split_heads_.erase(it);
  addOdometryEdgeLocked(head.node_id, node.kf.node_id, head.T_prev_cur, head.information);
  graph_joined_ = true;
  log::info("server: keyframe ", node.kf.keyframe_id, " of ", node.kf.robot_id,
            " came late: its odometry edge joins the chain split off at node ", head.node_id);
}

}  // namespace rgbdmap
