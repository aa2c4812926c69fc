#include "rgbdmap/server/server_config.hpp"

#include "rgbdmap/common/text_lines.hpp"

#include <sstream>

namespace rgbdmap {

namespace {

std::string joinList(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : ",") + s;
  return out;
}

}  // namespace

void readServerConfig(ConfigReader& r, ServerAppConfig* c) {
  MapServerConfig& s = c->server;
  r.read("server.map_dir", &s.map_dir);
  std::string robots = joinList(s.robots);
  r.read("server.robots", &robots);
  s.robots = splitList(robots);
  r.read("server.transport", &c->transport_url);
  r.read("server.keys_file", &c->keys_file);
  r.read("server.open_mode", &c->open_mode);
  r.read("server.store_sync", &s.store_sync);
  r.read("server.status_period_s", &s.status_period_s, 0.0, 3600.0);
  int capacity = static_cast<int>(s.ingest_queue_capacity);
  r.read("server.ingest_queue_capacity", &capacity, 1, 100000);
  s.ingest_queue_capacity = static_cast<size_t>(capacity);
  r.read("server.default_odometry_sigma_m", &s.default_odometry_sigma_m, 1e-4, 10.0);
  r.read("server.default_odometry_sigma_deg", &s.default_odometry_sigma_deg, 1e-3, 90.0);
  r.read("server.edge_sigma_floor_m", &s.edge_sigma_floor_m, 0.0, 10.0);
  r.read("server.edge_sigma_floor_deg", &s.edge_sigma_floor_deg, 0.0, 90.0);

  LoopCandidateConfig& lc = s.loop.candidates;
  r.read("loop.recent_k", &lc.recent_k, 0, 100);
  r.read("loop.random_l", &lc.random_l, 0, 100);
  r.read("loop.nearby_radius_m", &lc.nearby_radius_m, 0.0, 100.0);
  r.read("loop.nearby_angle_deg", &lc.nearby_angle_deg, 0.0, 180.0);
  r.read("loop.nearby_max", &lc.nearby_max, 0, 100);
  r.read("loop.retrieval_top_n", &lc.retrieval_top_n, 0, 100);
  r.read("loop.exclude_recent", &lc.exclude_recent, 0, 10000);
  r.read("loop.max_candidates", &lc.max_candidates, 1, 200);
  r.read("loop.seed", &lc.seed, 0u, 4294967295u);
  LoopVerifyConfig& lv = s.loop.verify;
  r.read("loop.min_matches", &lv.min_matches, 3, 10000);
  r.read("loop.min_inliers", &lv.min_inliers, 3, 10000);
  r.read("loop.min_inliers_retrieval", &lv.min_inliers_retrieval, 3, 10000);
  r.read("loop.k1", &lv.k1, 0.0, 100.0);
  r.read("loop.k2", &lv.k2, 0.0, 100.0);
  r.read("loop.max_motion_measure", &lv.max_motion_measure, 0.0, 100.0);
  r.read("loop.max_motion_measure_retrieval", &lv.max_motion_measure_retrieval, 0.0, 100.0);
  r.read("loop.min_refined_fraction", &lv.min_refined_fraction, 0.0, 1.0);
  r.read("loop.max_prior_disagreement", &lv.max_prior_disagreement, 0.0, 100.0);
  r.read("loop.min_retrieval_score", &s.loop.min_retrieval_score, 0.0, 1.0);

  PoseGraphConfig& g = s.graph;
  r.read("graph.loop_loss_scale", &g.loop_loss_scale, 0.01, 1000.0);
  r.read("graph.use_cauchy", &g.use_cauchy);
  r.read("graph.max_iterations", &g.max_iterations, 1, 10000);
  r.read("graph.max_solver_time_s", &g.max_solver_time_s, 0.001, 3600.0);
  r.read("graph.outlier_chi2", &g.outlier_chi2, 0.1, 1e6);
  r.read("graph.max_outlier_rounds", &g.max_outlier_rounds, 0, 100);
  r.read("graph.num_threads", &g.num_threads, 1, 256);

  r.read("map.enabled", &s.occupancy_enabled);
  OccupancyMapConfig& o = s.occupancy;
  r.read("map.resolution_m", &o.resolution_m, 0.005, 1.0);
  r.read("map.max_range_m", &o.max_range_m, 0.1, 50.0);
  r.read("map.min_range_m", &o.min_range_m, 0.0, 10.0);
  r.read("map.prob_hit", &o.prob_hit, 0.5, 1.0);
  r.read("map.prob_miss", &o.prob_miss, 0.0, 0.5);
  r.read("map.clamp_min", &o.clamp_min, 0.0, 1.0);
  r.read("map.clamp_max", &o.clamp_max, 0.0, 1.0);
  r.read("map.rebuild_translation_m", &o.rebuild_translation_m, 0.0, 10.0);
  r.read("map.rebuild_rotation_rad", &o.rebuild_rotation_rad, 0.0, 3.15);
  r.read("map.pixel_stride", &o.pixel_stride, 0, 64);
  r.read("map.cloud_voxel_fraction", &o.cloud_voxel_fraction, 0.0, 1.0);
  r.read("map.keep_colors", &o.keep_colors);
  r.read("map.stream_period_s", &s.map_stream_period_s, 0.0, 3600.0);
  SliceConfig& sl = s.slice;
  r.read("slice.period_s", &s.slice_period_s, 0.0, 3600.0);
  r.read("slice.size_m", &sl.size_m, 0.1, 100.0);
  r.read("slice.resolution_m", &sl.resolution_m, 0.005, 1.0);
  r.read("slice.z_min_m", &sl.z_min_m, -10.0, 10.0);
  r.read("slice.z_max_m", &sl.z_max_m, -10.0, 10.0);
  r.read("slice.occupied_threshold", &sl.occupied_threshold, 0.0, 1.0);
}

}  // namespace rgbdmap
