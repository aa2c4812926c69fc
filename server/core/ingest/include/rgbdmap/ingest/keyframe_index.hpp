#pragma once
// The server's keyframes by identity: (robot, sender session, segment, keyframe id) -> graph node id, the
// odometry chains (one segment of one robot process each), the nodes with their current poses, and the
// keyframes refused for good. Not thread-safe: the ingest pipeline guards it with its state lock.
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "rgbdmap/ingest/ingest_stats.hpp"
#include "rgbdmap/model/map_server_config.hpp"
#include "rgbdmap/model/server_keyframe.hpp"

namespace rgbdmap {

/// Identity of a keyframe: robot index, sender session, segment, keyframe id.
using KeyframeKey = std::tuple<int, int64_t, int, int>;

struct IndexedNode {
  ServerKeyframe kf;
  int robot = -1;
  int chain = -1;
  bool valid = false;  ///< false for ids whose stored record was lost (corrupt), kept as holes
};

class KeyframeIndex {
 public:
  /// The chain of (robot, session, segment), created on first use.
  int chainFor(int robot, int64_t session, int segment);
  /// A new chain for (robot, session, segment) that chainFor() returns from now on: the segment's odometry
  /// is split (a predecessor that never came).
  int newChain(int robot, int64_t session, int segment);
  /// Adds a node at its id and indexes its key. Ids beyond the last one leave invalid holes (records lost,
  /// or keyframes still waiting for their predecessor); a node may fill a hole later.
  void add(const IndexedNode& node);

  std::optional<int64_t> find(const KeyframeKey& key) const;
  /// The node of the same robot, session and segment with the greatest keyframe id below key's.
  std::optional<int64_t> latestBefore(const KeyframeKey& key) const;
  bool contains(const KeyframeKey& key) const { return node_of_.count(key) != 0; }
  bool refused(const KeyframeKey& key) const { return refused_.count(key) != 0; }
  void refuse(const KeyframeKey& key) { refused_.insert(key); }

  /// Node ids are dense: the next stored keyframe gets size().
  int64_t size() const { return static_cast<int64_t>(nodes_.size()); }
  bool validId(int64_t id) const { return id >= 0 && id < size() && nodes_[static_cast<size_t>(id)].valid; }
  const IndexedNode& node(int64_t id) const { return nodes_[static_cast<size_t>(id)]; }
  IndexedNode& node(int64_t id) { return nodes_[static_cast<size_t>(id)]; }
  const std::vector<IndexedNode>& nodes() const { return nodes_; }

  /// Map ids from the graph's connected components (each the component's first node id).
  void setComponents(std::vector<std::vector<int64_t>> components);
  size_t mapCount() const { return components_.size(); }

  /// Fills chains, map_id and merged of each robot's statistics (robot_index: the registry's index).
  void fillRobotStats(ServerRobotStats* robot, int robot_index) const;
  std::vector<ServerKeyframe> validKeyframes() const;  ///< in ingestion order

 private:
  struct Chain {
    int robot = 0;
    int64_t session = 0;
    int segment = 0;
  };
  std::vector<Chain> chains_;
  std::map<std::tuple<int, int64_t, int>, int> chain_of_;
  std::vector<IndexedNode> nodes_;  ///< index = node id
  std::map<KeyframeKey, int64_t> node_of_;
  std::set<KeyframeKey> refused_;  ///< refused for good (their successors start new chains)
  std::vector<std::vector<int64_t>> components_;
};

}  // namespace rgbdmap
