#include "scan_update.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace rgbdmap::detail {
namespace {

/// Two bits per cell (free ray cell, occupied endpoint) over the key box of one scan.
class KeyGrid {
 public:
  KeyGrid(const octomap::OcTreeKey& lo, const octomap::OcTreeKey& hi) : lo_(lo) {
    for (int a = 0; a < 3; ++a) n_[a] = static_cast<size_t>(hi[a] - lo[a]) + 1;
    const size_t cells = n_[0] * n_[1] * n_[2];
    free_.assign((cells + 63) / 64, 0);
    occupied_.assign((cells + 63) / 64, 0);
  }
  size_t index(const octomap::OcTreeKey& k) const {
    return ((static_cast<size_t>(k[0] - lo_[0]) * n_[1]) + (k[1] - lo_[1])) * n_[2] + (k[2] - lo_[2]);
  }
  /// Sets the bit; true if it was clear.
  static bool set(std::vector<uint64_t>& bits, size_t i) {
    const uint64_t mask = uint64_t{1} << (i & 63);
    if (bits[i >> 6] & mask) return false;
    bits[i >> 6] |= mask;
    return true;
  }
  octomap::OcTreeKey key(size_t i) const {
    const size_t z = i % n_[2], y = (i / n_[2]) % n_[1], x = i / (n_[2] * n_[1]);
    return octomap::OcTreeKey(static_cast<octomap::key_type>(lo_[0] + x),
                              static_cast<octomap::key_type>(lo_[1] + y),
                              static_cast<octomap::key_type>(lo_[2] + z));
  }
  std::vector<uint64_t> free_, occupied_;

 private:
  octomap::OcTreeKey lo_;
  size_t n_[3];
};

void collect(const KeyGrid& grid, ScanUpdate* out) {
  for (size_t w = 0; w < grid.free_.size(); ++w) {
    uint64_t f = grid.free_[w] & ~grid.occupied_[w];  // occupied wins within one scan (as OctoMap)
    uint64_t o = grid.occupied_[w];
    for (; f; f &= f - 1) out->free.push_back(grid.key(w * 64 + static_cast<size_t>(__builtin_ctzll(f))));
    for (; o; o &= o - 1) out->occupied.push_back(grid.key(w * 64 + static_cast<size_t>(__builtin_ctzll(o))));
  }
}

}  // namespace

ScanUpdate computeScanUpdate(const octomap::OcTree& geometry, const KeyframeCloud& cloud,
                             const SE3& T_map_cam, double max_range_m) {
  ScanUpdate out;
  const Eigen::Vector3d o = T_map_cam.translation();
  const octomap::point3d origin(static_cast<float>(o.x()), static_cast<float>(o.y()),
                                static_cast<float>(o.z()));
  octomap::OcTreeKey origin_key;
  if (!geometry.coordToKeyChecked(origin, origin_key)) return out;

  // Endpoints in map keys (truncated at max range); their key box bounds every ray.
  struct End {
    octomap::OcTreeKey key;
    bool hit;
  };
  std::vector<End> ends;
  ends.reserve(cloud.points_cam.size());
  octomap::OcTreeKey lo = origin_key, hi = origin_key;
  const Eigen::Matrix3f R = T_map_cam.linear().cast<float>();
  const Eigen::Vector3f t = T_map_cam.translation().cast<float>();
  for (const Eigen::Vector3f& p_cam : cloud.points_cam) {
    Eigen::Vector3f p = R * p_cam + t;
    const float range = (p - t).norm();
    const bool hit = range <= max_range_m;
    if (!hit) p = t + (p - t) * static_cast<float>(max_range_m / range);
    End e{octomap::OcTreeKey(), hit};
    if (!geometry.coordToKeyChecked(octomap::point3d(p.x(), p.y(), p.z()), e.key)) continue;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], e.key[a]);
      hi[a] = std::max(hi[a], e.key[a]);
    }
    ends.push_back(e);
  }
  if (ends.empty()) return out;

  KeyGrid grid(lo, hi);
  std::vector<uint64_t> cast((grid.free_.size()), 0);  // endpoint cells whose ray is already cast
  octomap::KeyRay ray;
  for (const End& e : ends) {
    const size_t i = grid.index(e.key);
    if (e.hit) KeyGrid::set(grid.occupied_, i);
    if (!KeyGrid::set(cast, i)) continue;  // discretised: one ray per endpoint cell
    if (!geometry.computeRayKeys(origin, geometry.keyToCoord(e.key), ray)) continue;
    for (const octomap::OcTreeKey& k : ray) KeyGrid::set(grid.free_, grid.index(k));
  }
  collect(grid, &out);
  return out;
}

void applyScanUpdate(octomap::OcTree* tree, const ScanUpdate& update,
                     std::vector<octomap::OcTreeKey>* changed) {
  const float miss = tree->getProbMissLog(), hit = tree->getProbHitLog();
  if (!changed) {
    for (const octomap::OcTreeKey& k : update.free) tree->updateNode(k, miss, false);
    for (const octomap::OcTreeKey& k : update.occupied) tree->updateNode(k, hit, false);
    return;
  }
  const float clamp_min = tree->getClampingThresMinLog(), clamp_max = tree->getClampingThresMaxLog();
  const auto apply = [&](const octomap::OcTreeKey& k, float delta) {
    // As OctoMap's change detection: a leaf is changed when it is new or its occupancy flips. A leaf (or
    // the pruned node holding it) already clamped in the update's direction does not change: updateNode
    // would abort early too.
    const octomap::OcTreeNode* before = tree->search(k);
    if (before && (delta >= 0.0f ? before->getLogOdds() >= clamp_max : before->getLogOdds() <= clamp_min))
      return;
    const bool was_occupied = before && tree->isNodeOccupied(before);
    const octomap::OcTreeNode* after = tree->updateNode(k, delta, false);
    if (!before || (after && tree->isNodeOccupied(after) != was_occupied)) changed->push_back(k);
  };
  for (const octomap::OcTreeKey& k : update.free) apply(k, miss);
  for (const octomap::OcTreeKey& k : update.occupied) apply(k, hit);
}

std::unique_ptr<octomap::OcTree> makeTree(const OccupancyMapConfig& config) {
  auto tree = std::make_unique<octomap::OcTree>(config.resolution_m);
  tree->setProbHit(config.prob_hit);
  tree->setProbMiss(config.prob_miss);
  tree->setClampingThresMin(config.clamp_min);
  tree->setClampingThresMax(config.clamp_max);
  tree->enableChangeDetection(false);
  return tree;
}

}  // namespace rgbdmap::detail
