#include "rgbdmap/ingest/chain_order.hpp"

#include <utility>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {

ChainOrder::ChainOrder(RobotRegistry& registry, const KeyframeIndex& index, int reorder_capacity,
                       Integrate integrate)
    : registry_(registry),
      index_(index),
      reorder_capacity_(reorder_capacity),
      integrate_(std::move(integrate)) {}

KeyframeKey ChainOrder::keyOf(const StoredKeyframe& stored) const {
  const msg::Keyframe& kf = stored.keyframe;
  return {registry_.index(kf.robot_id), stored.session, kf.segment_id, kf.keyframe_id};
}

std::optional<KeyframeKey> ChainOrder::predecessorOf(const StoredKeyframe& stored) const {
  const msg::Keyframe& kf = stored.keyframe;
  if (kf.previous_keyframe_id < 0) return std::nullopt;
  return KeyframeKey{registry_.index(kf.robot_id), stored.session, kf.segment_id, kf.previous_keyframe_id};
}

void ChainOrder::place(WaitingKeyframe waiting, const DecodedImages* images, bool live) {
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
  integrateWithSuccessors(std::move(waiting), images, live);
}

void ChainOrder::integrateWithSuccessors(WaitingKeyframe first, const DecodedImages* images, bool live) {
  std::vector<WaitingKeyframe> ready;
  ready.push_back(std::move(first));
  for (size_t i = 0; i < ready.size(); ++i) {
    const KeyframeKey key = keyOf(ready[i].stored);
    integrate_(ready[i], i == 0 ? images : nullptr, live);
    for (WaitingKeyframe& next : reorder_.takeSuccessors(key)) ready.push_back(std::move(next));
  }
}

void ChainOrder::giveUpWaiting(std::chrono::steady_clock::time_point now, double timeout_s, bool live) {
  while (std::optional<WaitingKeyframe> head = reorder_.takeRunToGiveUp(now, timeout_s, reorder_capacity_))
    integrateWithSuccessors(std::move(*head), nullptr, live);
}

void ChainOrder::predecessorRefused(const KeyframeKey& key) {
  for (WaitingKeyframe& w : reorder_.takeSuccessors(key))
    integrateWithSuccessors(std::move(w), nullptr, true);
}

}  // namespace rgbdmap
