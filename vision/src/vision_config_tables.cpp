#include "rgbdmap/vision/vision_config_tables.hpp"

namespace rgbdmap {

using R = ConfigRange;

const ConfigTable<OrbConfig>& orbConfigTable() {
  using C = OrbConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("n_features", &C::n_features, R::closed(50, 20000), "keypoints per frame after grid bucketing")
          .add("scale_factor", &C::scale_factor, R::closed(1.01, 2.0), "pyramid scale between levels")
          .add("n_levels", &C::n_levels, R::closed(1, 16), "pyramid levels")
          .add("fast_threshold", &C::fast_threshold, R::closed(1, 100), "FAST corner threshold")
          .add("grid_cols", &C::grid_cols, R::closed(1, 64),
               "bucketing grid: keeps features spread over the image")
          .add("grid_rows", &C::grid_rows, R::closed(1, 64), "")
          .add("min_depth_m", &C::min_depth_m, R::closed(0.0, 100.0),
               "depth outside [min, max] counts as missing")
          .add("max_depth_m", &C::max_depth_m, R::closed(0.01, 100.0), "")
          .add("depth_edge_radius_px", &C::depth_edge_radius_px, R::closed(0, 16),
               "a keypoint's depth counts as missing where the depth within this radius spans more than ...")
          .add("depth_edge_max_spread", &C::depth_edge_max_spread, R::closed(0.001, 10.0),
               "... this fraction of it (a depth discontinuity); radius 0 turns the test off");
  return table;
}

const ConfigTable<MatcherConfig>& matcherConfigTable() {
  using C = MatcherConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("k_min_distance", &C::k_min_distance, R::closed(1.0, 100.0),
               "Hu et al. 2017: drop matches with distance > k x the minimum distance ...")
          .add("min_distance_floor", &C::min_distance_floor, R::closed(0, 256),
               "... but never below this Hamming distance")
          .add("max_distance", &C::max_distance, R::closed(1, 256), "hard cap (256-bit descriptors)")
          .add("ratio", &C::ratio, R::closed(0.1, 1.0), "best / second-best (1 disables)");
  return table;
}

const ConfigTable<GuidedMatchConfig>& guidedMatchConfigTable() {
  using C = GuidedMatchConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("radius_px", &C::radius_px, R::closed(0.5, 200.0),
               "search radius around the projection, scaled by 1.2^octave")
          .add("max_distance", &C::max_distance, R::closed(1, 256), "Hamming distance accepted")
          .add("ratio", &C::ratio, R::closed(0.1, 1.0), "best vs second-best within the radius");
  return table;
}

const ConfigTable<RansacConfig>& ransacConfigTable() {
  using C = RansacConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("max_iterations", &C::max_iterations, R::closed(1, 100000), "")
          .add("confidence", &C::confidence, R::closed(0.5, 0.999999), "")
          .add("reprojection_threshold_px", &C::reprojection_threshold_px, R::closed(0.1, 100.0),
               "inlier if the reprojection error is below this ...")
          .add("depth_threshold_rel", &C::depth_threshold_rel, R::closed(0.001, 1.0),
               "... and the depth agrees within this fraction of the depth")
          .add("min_inliers", &C::min_inliers, R::closed(3, 10000), "")
          .add("seed", &C::seed, R::closed(0, 4294967295.0), "deterministic sampling");
  return table;
}

const ConfigTable<RefineConfig>& refineConfigTable() {
  using C = RefineConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("iterations", &C::iterations, R::closed(0, 100), "Gauss-Newton iterations per round")
          .add("rounds", &C::rounds, R::closed(1, 10), "rounds of (optimise, re-classify outliers)")
          .add("pixel_sigma", &C::pixel_sigma, R::closed(0.01, 100.0),
               "keypoint noise at pyramid level 0 (px)")
          .add("depth_sigma_coeff", &C::depth_sigma_coeff, R::closed(1e-6, 1.0),
               "depth sigma = coeff * z^2 (m)")
          .add("huber_delta", &C::huber_delta, R::closed(0.01, 100.0),
               "robust kernel on whitened residual norms (sqrt(chi2_2dof 95%))")
          .add("outlier_chi2", &C::outlier_chi2, R::closed(0.1, 1000.0),
               "whitened squared error above which a match is an outlier (3 dof 95%)");
  return table;
}

}  // namespace rgbdmap
