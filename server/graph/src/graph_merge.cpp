// Map merging: a robot's submap first connected to the anchored map by inter-robot loop edges starts in its
// own odometry frame. Before the solve it is moved rigidly by the correction most of those edges agree on
// (pairwise consistency), so the robust solve starts near the answer and a single wrong edge cannot place it.
#include <algorithm>

#include "graph_internal.hpp"

namespace rgbdmap::graph_detail {

namespace {

/// Correction C applied to the submap so that the edge holds: C * T_map_moving = implied pose.
SE3 impliedCorrection(const PoseGraphEdge& e, const EdgeEnds& ends, bool to_is_moving,
                      const std::vector<SE3>& T_map_kf) {
  if (to_is_moving) {
    return T_map_kf[ends.from] * e.T_from_to * T_map_kf[ends.to].inverse();
  }
  return T_map_kf[ends.to] * e.T_from_to.inverse() * T_map_kf[ends.from].inverse();
}

bool agree(const SE3& a, const SE3& b, double max_t, double max_r) {
  const SE3 d = a.inverse() * b;
  return d.translation().norm() < max_t && se3::rotationAngle(d) < max_r;
}

/// The candidate with the most agreeing candidates (ties: the first).
SE3 consensus(const std::vector<SE3>& candidates, const PoseGraphConfig& config) {
  size_t best = 0;
  int best_support = -1;
  for (size_t i = 0; i < candidates.size(); ++i) {
    int support = 0;
    for (const auto& other : candidates) {
      support += agree(candidates[i], other, config.merge_consensus_translation_m,
                       config.merge_consensus_rotation_rad);
    }
    if (support > best_support) {
      best_support = support;
      best = i;
    }
  }
  return candidates[best];
}

}  // namespace

int alignSubmaps(const std::vector<PoseGraphEdge>& edges, const std::vector<EdgeEnds>& ends,
                 const std::vector<bool>& enabled, const std::vector<bool>& fixed,
                 const PoseGraphConfig& config, std::vector<SE3>* T_map_kf, std::vector<long>* moved_by) {
  const size_t n = T_map_kf->size();
  if (moved_by) moved_by->assign(n, -1);
  std::vector<bool> intra(edges.size());
  for (size_t k = 0; k < edges.size(); ++k) intra[k] = enabled[k] && edges[k].kind != EdgeKind::kInterRobot;
  const std::vector<size_t> submap = componentLabels(n, ends, intra);
  std::vector<bool> anchored(n, false);  // indexed by submap label
  for (size_t i = 0; i < n; ++i) anchored[submap[i]] = anchored[submap[i]] || fixed[i];

  int moved = 0;
  for (bool progress = true; progress;) {
    progress = false;
    for (size_t label = 0; label < n; ++label) {
      if (anchored[label] || submap[label] != label) continue;
      std::vector<SE3> candidates;
      for (size_t k = 0; k < edges.size(); ++k) {
        if (!enabled[k] || edges[k].kind != EdgeKind::kInterRobot) continue;
        const size_t sf = submap[ends[k].from], st = submap[ends[k].to];
        if (st == label && anchored[sf])
          candidates.push_back(impliedCorrection(edges[k], ends[k], true, *T_map_kf));
        if (sf == label && anchored[st])
          candidates.push_back(impliedCorrection(edges[k], ends[k], false, *T_map_kf));
      }
      if (candidates.empty()) continue;
      const SE3 C = consensus(candidates, config);
      if (!agree(C, SE3::Identity(), config.merge_align_translation_m, config.merge_align_rotation_rad)) {
        for (size_t i = 0; i < n; ++i) {
          if (submap[i] != label) continue;
          (*T_map_kf)[i] = se3::normalized(C * (*T_map_kf)[i]);
          if (moved_by) (*moved_by)[i] = static_cast<long>(label);
        }
        ++moved;
      }
      anchored[label] = true;
      progress = true;
    }
  }
  return moved;
}

}  // namespace rgbdmap::graph_detail
