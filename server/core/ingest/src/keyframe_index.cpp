#include "rgbdmap/ingest/keyframe_index.hpp"

#include <utility>

namespace rgbdmap {

int KeyframeIndex::chainFor(int robot, int64_t session, int segment) {
  const auto key = std::make_tuple(robot, session, segment);
  const auto it = chain_of_.find(key);
  if (it != chain_of_.end()) return it->second;
  chains_.push_back({robot, session, segment});
  chain_of_.emplace(key, static_cast<int>(chains_.size() - 1));
  return static_cast<int>(chains_.size() - 1);
}

int KeyframeIndex::newChain(int robot, int64_t session, int segment) {
  chains_.push_back({robot, session, segment});
  const int chain = static_cast<int>(chains_.size() - 1);
  chain_of_[std::make_tuple(robot, session, segment)] = chain;
  return chain;
}

void KeyframeIndex::add(const IndexedNode& node) {
  const auto id = static_cast<size_t>(node.kf.node_id);
  if (id < nodes_.size()) {
    nodes_[id] = node;  // a hole filled: the keyframe waited for its predecessor
  } else {
    nodes_.resize(id);
    nodes_.push_back(node);
  }
  node_of_[{node.robot, node.kf.session, node.kf.segment, node.kf.keyframe_id}] = id;
}

std::optional<int64_t> KeyframeIndex::find(const KeyframeKey& key) const {
  const auto it = node_of_.find(key);
  if (it == node_of_.end()) return std::nullopt;
  return it->second;
}

std::optional<int64_t> KeyframeIndex::latestBefore(const KeyframeKey& key) const {
  auto it = node_of_.lower_bound(key);
  if (it == node_of_.begin()) return std::nullopt;
  --it;
  const KeyframeKey& found = it->first;
  if (std::get<0>(found) != std::get<0>(key) || std::get<1>(found) != std::get<1>(key) ||
      std::get<2>(found) != std::get<2>(key))
    return std::nullopt;
  return it->second;
}

void KeyframeIndex::setComponents(std::vector<std::vector<int64_t>> components) {
  components_ = std::move(components);
  for (const auto& component : components_) {
    const int map_id = static_cast<int>(component.front());
    for (const int64_t id : component) nodes_[static_cast<size_t>(id)].kf.map_id = map_id;
  }
}

void KeyframeIndex::fillRobotStats(ServerRobotStats* r, int robot_index) const {
  for (const Chain& c : chains_) r->chains += c.robot == robot_index;
  const IndexedNode* newest = nullptr;
  for (const IndexedNode& n : nodes_)
    if (n.kf.robot_id == r->robot_id) newest = &n;
  if (!newest) return;
  r->map_id = newest->kf.map_id;
  for (const IndexedNode& n : nodes_)
    if (n.kf.map_id == r->map_id && n.kf.robot_id != r->robot_id) r->merged = true;
}

std::vector<ServerKeyframe> KeyframeIndex::validKeyframes() const {
  std::vector<ServerKeyframe> out;
  out.reserve(nodes_.size());
  for (const IndexedNode& n : nodes_)
    if (n.valid) out.push_back(n.kf);
  return out;
}

}  // namespace rgbdmap
