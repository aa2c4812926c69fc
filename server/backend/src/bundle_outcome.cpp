#include "rgbdmap/backend/bundle_outcome.hpp"

#include <algorithm>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/graph/pose_graph_residual.hpp"

namespace rgbdmap {

std::string BundleOutcome::check(const std::vector<std::pair<int64_t, SE3>>& proposed) {
  checked_.moved.clear();
  for (const auto& [id, T] : proposed) checked_.moved.push_back(id);
  checked_.edges = essential_->covisibleEdgeChanges(proposed);
  const double max_t = config_->max_edge_change_m, max_deg = config_->max_edge_change_deg;
  for (const CovisibleEdge& c : checked_.edges)
    if ((max_t > 0.0 && c.t > max_t) || (max_deg > 0.0 && c.deg > max_deg))
      return "it would change edge " + std::to_string(c.edge->id) + " (" + std::to_string(c.edge->from) +
             "-" + std::to_string(c.edge->to) + ", keyframes sharing landmarks) by " + std::to_string(c.t) +
             " m and " + std::to_string(c.deg) + " deg";
  return "";
}

std::vector<CovisibleEdge>* BundleOutcome::checkedEdges(const std::vector<int64_t>& moved) {
  return checked_.moved == moved ? &checked_.edges : nullptr;
}

bool BundleOutcome::count(const BundleResult& r, const char* kind, BundleAdjustmentStats* counters) {
  if (r.refused) {
    ++counters->refused;
    log::warn("optimiser: ", kind, " bundle adjustment of ", r.report.frames, " keyframes",
              r.report.out_of_time ? " (out of time)" : "", " refused: ", r.error);
  }
  counters->parts_kept += r.parts_kept;
  counters->part_shift_m_max = std::max(counters->part_shift_m_max, r.part_shift_m);
  return r.ok;
}

std::vector<BundlePrior> BundleOutcome::stepPriors(int map) const {
  std::vector<BundlePrior> out;
  if (!config_->global_step_priors) return out;
  const std::vector<int64_t>& disabled = graph_->disabledEdges();
  const auto inMap = [&](int64_t id) {
    return topology_->contains(id) && topology_->mapOf(id) == map && landmarks_->contains(id);
  };
  for (const PoseGraphEdge& e : graph_->edges()) {
    if (!inMap(e.from) || !inMap(e.to) || std::binary_search(disabled.begin(), disabled.end(), e.id))
      continue;
    if (landmarks_->sharedLandmarks(e.from, e.to) >= config_->landmarks.min_covisibility) continue;
    Mat6 sqrt_information;
    if (!sqrtInformation(residualInformation(e.T_from_to, e.information), &sqrt_information)) continue;
    out.push_back({e.from, e.to, e.T_from_to, sqrt_information});
  }
  return out;
}

}  // namespace rgbdmap
