#include "growth_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <utility>

#include "rgbdmap/dataset/evaluation.hpp"

namespace rgbdmap::bench {

void printServerTotals(const MapServerStats& l) {
  std::printf(
      "loop candidates verified: %d, matched all against all: %d without a prior pose, %d after too few "
      "matches by projection (%d of those verified; %d more rejected without it, "
      "loop.max_fallbacks_per_keyframe)\n",
      l.loop_candidates, l.loop_brute_force_no_prior, l.loop_brute_force_fallback,
      l.loop_brute_force_fallback_verified, l.loop_fallbacks_skipped);
  std::printf(
      "keyframe features: %zu in RAM (server.features_in_memory), %llu read back from the store, %llu "
      "reads failed, %d loop candidates skipped for them\n",
      l.features_resident, static_cast<unsigned long long>(l.features_loads),
      static_cast<unsigned long long>(l.features_load_failures), l.loop_features_unavailable);
  const LandmarkStats& lm = l.ba.landmarks;
  std::printf(
      "landmark tracks: %lld keyframes, %lld landmarks, %lld observations (%.1f per landmark), %.0f MB; "
      "retrieval index %.0f MB (%.1f KB per keyframe)\n",
      static_cast<long long>(lm.keyframes), static_cast<long long>(lm.landmarks),
      static_cast<long long>(lm.observations),
      lm.landmarks > 0 ? static_cast<double>(lm.observations) / static_cast<double>(lm.landmarks) : 0.0,
      static_cast<double>(lm.memory_bytes) / 1e6, static_cast<double>(l.retrieval_index_bytes) / 1e6,
      l.keyframes > 0 ? static_cast<double>(l.retrieval_index_bytes) / 1e3 / l.keyframes : 0.0);
  std::printf(
      "freed heap given back (server.memory_trim_period_s): %llu trims, %.0f MB released, %.0f ms CPU\n",
      static_cast<unsigned long long>(l.memory_trims),
      static_cast<double>(l.memory_trim_released_bytes) / 1e6, l.memory_trim_cpu_ms);
}

void printMapWorker(const MapServerStats& m) {
  std::printf(
      "map worker: octree insertion %.1f ms CPU per keyframe (median), slice %.1f ms (median, %llu sent), "
      "%llu keyframes queued without their images (read back from the store: the worker was behind), %llu "
      "pose updates replaced by a newer one before they were applied, %llu "
      "map updates (%.1f MB); kept clouds %.0f MB in RAM, %zu spilled (file %.0f MB, %llu failures), "
      "octrees %.0f MB, stream journals %.0f MB\n",
      m.map_insert_ms_median, m.slice_ms_median, static_cast<unsigned long long>(m.slices_sent),
      static_cast<unsigned long long>(m.map_images_deferred),
      static_cast<unsigned long long>(m.map_pose_updates_coalesced),
      static_cast<unsigned long long>(m.map_updates_sent), static_cast<double>(m.map_bytes_sent) / 1e6,
      static_cast<double>(m.map_clouds_memory_bytes) / 1e6, m.map_clouds_spilled,
      static_cast<double>(m.map_spill_file_bytes) / 1e6,
      static_cast<unsigned long long>(m.map_spill_failures),
      static_cast<double>(m.map_tree_memory_bytes) / 1e6, static_cast<double>(m.map_journal_bytes) / 1e6);
}

void printLapAte(const Trajectory& truth, const Trajectory& estimate, int per_lap,
                 const std::vector<int>& plan) {
  // The jumps between rooms are blind (no overlap, one noisy odometry step of up to hundreds of metres), so
  // the global ATE grows with the number of rooms whatever the server does. What the server's optimisation
  // decides is each lap's shape: the ATE of each lap aligned on its own, over the first and the last tenth
  // of the laps, shows whether the map's accuracy holds as it grows.
  // Each lap's ATE (aligned on its own); -1 when it has too few poses.
  const size_t laps_run = (truth.size() + per_lap - 1) / per_lap;
  std::vector<double> lap_ate(laps_run, -1.0);
  for (size_t lap = 0; lap < laps_run; ++lap) {
    Trajectory t, e;
    for (size_t i = lap * per_lap; i < std::min(truth.size(), (lap + 1) * per_lap); ++i)
      t.push_back(truth[i]);
    if (t.size() < 8) continue;
    for (const auto& p : estimate)
      if (p.timestamp >= t.front().timestamp && p.timestamp <= t.back().timestamp) e.push_back(p);
    if (e.size() < 8) continue;
    if (const auto a = computeAte(t, e)) lap_ate[lap] = a->rmse;
  }
  const auto lapAte = [&](size_t first, size_t last) {
    double sum = 0.0;
    int n = 0;
    for (size_t lap = first; lap < last; ++lap)
      if (lap_ate[lap] >= 0.0) sum += lap_ate[lap], ++n;
    return n > 0 ? sum / n : -1.0;
  };
  const size_t lap_tenth = std::max<size_t>(1, laps_run / 10);
  std::printf(
      "per-lap ATE (each lap aligned on its own), mean: first tenth %.4f m, last tenth %.4f m, all %.4f m\n",
      lapAte(0, lap_tenth), lapAte(laps_run - std::min(laps_run, lap_tenth), laps_run), lapAte(0, laps_run));
  std::vector<size_t> worst(laps_run);
  for (size_t i = 0; i < laps_run; ++i) worst[i] = i;
  std::sort(worst.begin(), worst.end(), [&](size_t a, size_t b) { return lap_ate[a] > lap_ate[b]; });
  std::printf("worst laps (lap:room ATE):");
  for (size_t k = 0; k < std::min<size_t>(8, worst.size()); ++k)
    std::printf(" %zu:%d %.3f m", worst[k], plan[worst[k]], lap_ate[worst[k]]);
  std::printf("\n");
}

void printLoopsAgainstTruth(const MapServer& server, const Trajectory& truth, int per_lap,
                            const std::vector<int>& plan) {
  // Every loop against the truth: one far from the true relative pose is a false match; the consistency
  // check should hold it out (enabled false).
  std::map<int64_t, int> index_of_node;
  for (const ServerKeyframe& k : server.keyframes()) index_of_node[k.node_id] = k.keyframe_id;
  int checked = 0, wrong = 0, wrong_enabled = 0, true_disabled = 0;
  std::vector<std::pair<double, std::string>> worst_loops;  // false loops still enabled
  for (const ServerLoop& l : server.loops()) {
    const auto a = index_of_node.find(l.from_node), b = index_of_node.find(l.to_node);
    if (a == index_of_node.end() || b == index_of_node.end() || a->second >= static_cast<int>(truth.size()) ||
        b->second >= static_cast<int>(truth.size()))
      continue;
    const SE3 d =
        (truth[a->second].T_world_cam.inverse() * truth[b->second].T_world_cam).inverse() * l.T_from_to;
    const double dt = d.translation().norm();
    const double dr = Eigen::AngleAxisd(d.rotation()).angle() * 180.0 / M_PI;
    ++checked;
    const bool is_false = dt > 0.05 || dr > 2.0;
    wrong += is_false ? 1 : 0;
    true_disabled += !is_false && !l.enabled ? 1 : 0;
    if (!is_false || !l.enabled) continue;
    ++wrong_enabled;
    char line[160];
    std::snprintf(line, sizeof line, " %d(lap %d room %d)-%d(lap %d room %d) %.2f m %.1f deg", a->second,
                  a->second / per_lap, plan[a->second / per_lap], b->second, b->second / per_lap,
                  plan[b->second / per_lap], dt, dr);
    worst_loops.emplace_back(dt + dr / 10.0, line);
  }
  std::sort(worst_loops.rbegin(), worst_loops.rend());
  std::printf(
      "loops against the truth: %d checked, %d false (off by > 5 cm or 2 deg) of which %d enabled at the "
      "end, "
      "%d true ones disabled%s",
      checked, wrong, wrong_enabled, true_disabled, wrong_enabled > 0 ? "; worst enabled:" : "");
  for (size_t k = 0; k < std::min<size_t>(6, worst_loops.size()); ++k)
    std::printf("%s", worst_loops[k].second.c_str());
  std::printf("\n");
}

}  // namespace rgbdmap::bench
