#include "rgbdmap/loop/loop_config_tables.hpp"

namespace rgbdmap {

using R = ConfigRange;

const ConfigTable<LoopCandidateConfig>& loopCandidateConfigTable() {
  using C = LoopCandidateConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("recent_k", &C::recent_k, R::closed(0, 100),
               "local loops: the k most recent keyframes of the same robot")
          .add("random_l", &C::random_l, R::closed(0, 100),
               "random loops: l random older keyframes of the same robot")
          .add("nearby_radius_m", &C::nearby_radius_m, R::closed(0.0, 100.0),
               "nearby: camera centres within this distance in the same map ...")
          .add("nearby_angle_deg", &C::nearby_angle_deg, R::closed(0.0, 180.0),
               "... and optical axes within this angle")
          .add("nearby_max", &C::nearby_max, R::closed(0, 100),
               "closest nearby keyframes kept (not already recent)")
          .add("retrieval_top_n", &C::retrieval_top_n, R::closed(0, 100),
               "appearance retrieval over all robots' keyframes (binary words, tf-idf)")
          .add("exclude_recent", &C::exclude_recent, R::closed(0, 10000),
               "retrieval ignores this many most recent keyframes of the same robot")
          .add("max_candidates", &C::max_candidates, R::closed(1, 200),
               "cap on the union of all sources per new keyframe")
          .add("seed", &C::seed, R::closed(0, 4294967295.0), "random-loop sampling");
  return table;
}

const ConfigTable<LoopVerifyConfig>& loopVerifyConfigTable() {
  using C = LoopVerifyConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("min_matches", &C::min_matches, R::closed(3, 10000), "descriptor matches needed to try RANSAC")
          .add("min_inliers", &C::min_inliers, R::closed(3, 10000), "refined inliers to accept a local loop")
          .add("min_inliers_retrieval", &C::min_inliers_retrieval, R::closed(3, 10000),
               "... and a retrieval hit (aliasing shows up there)")
          .add("k1", &C::k1, R::closed(0.0, 100.0),
               "motion measure E = k1 |t| + k2 |euler| (1/m, 1/rad), paper eq. (5)")
          .add("k2", &C::k2, R::closed(0.0, 100.0), "")
          .add("max_motion_measure", &C::max_motion_measure, R::openClosed(0.0, 100.0),
               "E threshold for local candidates")
          .add("max_motion_measure_retrieval", &C::max_motion_measure_retrieval, R::openClosed(0.0, 100.0),
               "E threshold for retrieval hits")
          .add("min_refined_fraction", &C::min_refined_fraction, R::closed(0.0, 1.0),
               "refined pose must keep this share of RANSAC's inliers")
          .add("max_prior_disagreement", &C::max_prior_disagreement, R::openClosed(0.0, 100.0),
               "E of verified vs. estimated relative pose, same map only");
  return table;
}

const ConfigTable<BinaryWordsConfig>& binaryWordsConfigTable() {
  using C = BinaryWordsConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("tables", &C::tables, R::atLeast(1), "independent hash tables (words per descriptor)")
          .add("bits_per_word", &C::bits_per_word, R::closed(1, 20), "sampled bits per table")
          .add("stop_word_fraction", &C::stop_word_fraction, R::openClosed(0.0, 1.0),
               "words in more than this fraction of keyframes are skipped at query");
  return table;
}

const ConfigTable<LoopConsistencyConfig>& loopConsistencyConfigTable() {
  using C = LoopConsistencyConfig;
  static const ConfigTable<C> table = ConfigTable<C>()
                                          .add("max_translation_m", &C::max_translation_m, R::above(0.0),
                                               "triangles closing worse are contradictions")
                                          .add("max_rotation_deg", &C::max_rotation_deg, R::above(0.0), "");
  return table;
}

const ConfigTable<LoopDetectorConfig>& loopDetectorConfigTable() {
  using C = LoopDetectorConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .nest("", &C::candidates, loopCandidateConfigTable())
          .nest("", &C::verify, loopVerifyConfigTable())
          .add("min_retrieval_score", &C::min_retrieval_score, R::closed(0.0, 1.0),
               "retrieval hits scoring below this are not candidates")
          .add("prior_max_hops", &C::prior_max_hops, R::closed(0, 1000),
               "candidates within this many graph hops are checked against the measured path (0: off)")
          .add("prior_max_nodes", &C::prior_max_nodes, R::closed(1, 1000000),
               "... of at most this many keyframes")
          .add("max_fallbacks_per_keyframe", &C::max_fallbacks_per_keyframe, R::closed(0, 1000),
               "candidates with a prior a keyframe may match all against all when matching by projection "
               "finds too few, best retrieval score first (0: no limit)")
          .nest("words.", &C::words, binaryWordsConfigTable(), false)
          .nest("consistency.", &C::consistency, loopConsistencyConfigTable(), false);
  return table;
}

}  // namespace rgbdmap
