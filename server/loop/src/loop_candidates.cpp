#include "rgbdmap/loop/loop_candidates.hpp"

#include <algorithm>
#include <cmath>

namespace rgbdmap {
namespace {

class CandidateSet {
 public:
  void add(int id, uint8_t source, double score = 0.0) {
    for (LoopCandidate& c : list_) {
      if (c.keyframe_id != id) continue;
      c.sources |= source;
      c.retrieval_score = std::max(c.retrieval_score, score);
      return;
    }
    list_.push_back({id, source, score});
  }
  bool contains(int id) const {
    return std::any_of(list_.begin(), list_.end(),
                       [id](const LoopCandidate& c) { return c.keyframe_id == id; });
  }
  std::vector<LoopCandidate> take(int cap) {
    if (cap >= 0 && list_.size() > static_cast<size_t>(cap)) list_.resize(static_cast<size_t>(cap));
    return std::move(list_);
  }

 private:
  std::vector<LoopCandidate> list_;
};

std::vector<const KeyframeSummary*> sameRobot(const KeyframeSummary& query,
                                              const std::vector<KeyframeSummary>& stored) {
  std::vector<const KeyframeSummary*> out;
  for (const KeyframeSummary& s : stored)
    if (s.robot_id == query.robot_id && s.id != query.id) out.push_back(&s);
  return out;
}

void addNearby(const KeyframeSummary& query, const std::vector<KeyframeSummary>& stored,
               const LoopCandidateConfig& config, CandidateSet* set) {
  std::vector<std::pair<double, int>> near;
  for (const KeyframeSummary& s : stored) {
    if (s.id == query.id || set->contains(s.id)) continue;
    if (!isNearby(query, s, config.nearby_radius_m, config.nearby_angle_deg)) continue;
    near.emplace_back((s.T_map_kf.translation() - query.T_map_kf.translation()).norm(), s.id);
  }
  std::sort(near.begin(), near.end());
  for (size_t i = 0; i < near.size() && static_cast<int>(i) < config.nearby_max; ++i)
    set->add(near[i].second, kSourceNearby);
}

}  // namespace

const char* candidateSourceName(int bit) {
  static const char* const kNames[kCandidateSourceCount] = {"recent", "random", "nearby", "retrieval"};
  return bit >= 0 && bit < kCandidateSourceCount ? kNames[bit] : "unknown";
}

bool isNearby(const KeyframeSummary& a, const KeyframeSummary& b, double radius_m, double angle_deg) {
  if (a.map_id != b.map_id) return false;
  if ((a.T_map_kf.translation() - b.T_map_kf.translation()).norm() > radius_m) return false;
  const Vec3 axis_a = a.T_map_kf.linear().col(2), axis_b = b.T_map_kf.linear().col(2);
  const double cos_angle = std::clamp(axis_a.dot(axis_b), -1.0, 1.0);
  return std::acos(cos_angle) <= angle_deg * M_PI / 180.0;
}

std::vector<LoopCandidate> selectLoopCandidates(const KeyframeSummary& query,
                                                const std::vector<KeyframeSummary>& stored,
                                                const std::vector<RetrievalHit>& hits,
                                                const LoopCandidateConfig& config, std::mt19937* rng) {
  CandidateSet set;
  const std::vector<const KeyframeSummary*> own = sameRobot(query, stored);
  const size_t n_recent = std::min(own.size(), static_cast<size_t>(std::max(0, config.recent_k)));
  for (size_t i = own.size() - n_recent; i < own.size(); ++i) set.add(own[i]->id, kSourceRecent);
  for (const RetrievalHit& h : hits)
    if (h.keyframe_id != query.id) set.add(h.keyframe_id, kSourceRetrieval, h.score);
  addNearby(query, stored, config, &set);
  std::vector<const KeyframeSummary*> older(own.begin(), own.end() - static_cast<long>(n_recent));
  if (rng != nullptr && config.random_l > 0 && !older.empty()) {
    std::shuffle(older.begin(), older.end(), *rng);
    const size_t n = std::min(older.size(), static_cast<size_t>(config.random_l));
    for (size_t i = 0; i < n; ++i) set.add(older[i]->id, kSourceRandom);
  }
  return set.take(config.max_candidates);
}

}  // namespace rgbdmap
