// The map optimiser (issue #14): pose graph + landmark tracks + local and global bundle adjustment on one
// worker, fed with batches as the ingest worker does. On a synthetic scene with exact ground truth
// (ba_synth): BA brings the keyframes much closer to the truth than the pose graph alone; a false loop (a
// wrong relative pose with wrong matches) is disabled by the pose graph, its matches never enter the tracks,
// and the result stays within a stated bound of the clean one.
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <functional>
#include <mutex>
#include <random>

#include "../../server/core/src/map_optimizer.hpp"
#include "rgbdmap/ba/ba_synth.hpp"
#include "rgbdmap/graph/pose_graph_synth.hpp"

namespace rgbdmap {
namespace {

constexpr int kKeyframes = 30;

struct Collector {
  std::mutex mutex;
  std::condition_variable cv;
  std::shared_ptr<const MapOptimization> latest;

  void operator()(const std::shared_ptr<const MapOptimization>& r) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      latest = r;
    }
    cv.notify_all();
  }
  std::shared_ptr<const MapOptimization> waitFor(uint64_t revision) {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait_for(lock, std::chrono::seconds(60), [&] { return latest && latest->revision >= revision; });
    return latest;
  }
};

PoseGraphEdge edge(int64_t id, int64_t from, int64_t to, const SE3& T_from_to, EdgeKind kind, double sigma_t,
                   double sigma_r) {
  PoseGraphEdge e;
  e.id = id;
  e.from = from;
  e.to = to;
  e.T_from_to = T_from_to;
  e.kind = kind;
  e.information.setZero();
  e.information.diagonal() << Vec3::Constant(1.0 / (sigma_t * sigma_t)),
      Vec3::Constant(1.0 / (sigma_r * sigma_r));
  return e;
}

SE3 noisy(const SE3& T, std::mt19937& rng, double sigma_t, double sigma_r) {
  std::normal_distribution<double> n(0.0, 1.0);
  return se3::exp((Vec6() << sigma_t * n(rng), sigma_t * n(rng), sigma_t * n(rng), sigma_r * n(rng),
                   sigma_r * n(rng), sigma_r * n(rng))
                      .finished()) *
         T;
}

struct Outcome {
  double rms_m = 0.0;
  std::shared_ptr<const MapOptimization> result;
};

/// Feeds the scene keyframe by keyframe (odometry with drift, loops to the 3 previous keyframes with their
/// true matches), optionally a false loop, then asks for a global BA; returns the keyframe position error.
Outcome runScene(const BaSynthScene& s, bool ba, bool false_loop,
                 const std::function<void(MapOptimizerConfig*)>& adjust = {}, bool one_at_a_time = false) {
  MapOptimizerConfig config;
  config.ba.enabled = ba;
  if (adjust) adjust(&config);
  Collector results;
  MapOptimizer optimizer(config, [&](const std::shared_ptr<const MapOptimization>& r) { results(r); });
  std::mt19937 rng(3);
  SE3 T_odom = s.T_map_kf[0];
  int64_t edge_id = 0;
  uint64_t revision = 0;
  for (int k = 0; k < kKeyframes; ++k) {
    OptimizerBatch b;
    if (k > 0) {
      const SE3 T_prev_cur = noisy(s.T_map_kf[k - 1].inverse() * s.T_map_kf[k], rng, 0.004, 0.003);
      T_odom = T_odom * T_prev_cur;
      b.edges.push_back(edge(edge_id++, k, k - 1, T_prev_cur.inverse(), EdgeKind::kOdometry, 0.01, 0.005));
    }
    b.nodes.push_back({k, 0, T_odom, k == 0});
    b.keyframes.push_back(synthKeyframe(s, k, T_odom));
    for (int j = std::max(0, k - 3); j < k - 1; ++j) {
      const SE3 measured = noisy(s.T_map_kf[k].inverse() * s.T_map_kf[j], rng, 0.003, 0.002);
      b.edges.push_back(edge(edge_id, k, j, measured, EdgeKind::kLoop, 0.01, 0.005));
      b.matches[edge_id++] = synthTrueMatches(s, k, j);
      b.solve = true;
    }
    if (false_loop && k == kKeyframes - 1) {
      // "Keyframe 29 is where keyframe 2 was": the wrong relative pose with wrong (random) matches.
      b.edges.push_back(edge(edge_id, k, 2, SE3::Identity(), EdgeKind::kLoop, 0.01, 0.005));
      EdgeMatches wrong{k, 2, {}};
      std::uniform_int_distribution<int> fk(0, static_cast<int>(s.features[k]->size()) - 1);
      std::uniform_int_distribution<int> f2(0, static_cast<int>(s.features[2]->size()) - 1);
      for (int i = 0; i < 200; ++i) wrong.pairs.emplace_back(fk(rng), f2(rng));
      b.matches[edge_id++] = wrong;
      b.solve = true;
    }
    revision = optimizer.submit(std::move(b));
    if (one_at_a_time) results.waitFor(revision);
  }
  OptimizerBatch global;
  global.global = true;
  revision = optimizer.submit(std::move(global));
  Outcome out;
  out.result = results.waitFor(revision);
  EXPECT_TRUE(out.result && out.result->revision >= revision) << "no result";
  if (!out.result) return out;
  double sum = 0.0;
  for (int k = 0; k < kKeyframes; ++k)
    sum += (out.result->graph.T_map_kf.at(k).translation() - s.T_map_kf[k].translation()).squaredNorm();
  out.rms_m = std::sqrt(sum / kKeyframes);
  return out;
}

BaSynthScene scene() {
  BaSynthConfig c;
  c.keyframes = kKeyframes;
  c.points = 3000;
  return makeBaSynthScene(c);
}

TEST(MapOptimizer, BundleAdjustmentBeatsThePoseGraphAlone) {
  const BaSynthScene s = scene();
  const Outcome graph_only = runScene(s, false, false);
  const Outcome with_ba = runScene(s, true, false);
  ASSERT_TRUE(with_ba.result);
  const BundleAdjustmentStats& ba = with_ba.result->ba;
  std::printf(
      "[ measured ] keyframe rms: pose graph %.4f m, with BA %.5f m; %lld landmarks, %lld local + %lld "
      "global BA\n",
      graph_only.rms_m, with_ba.rms_m, static_cast<long long>(ba.landmarks.landmarks),
      static_cast<long long>(ba.local_runs), static_cast<long long>(ba.global_runs));
  EXPECT_LT(with_ba.rms_m, 0.5 * graph_only.rms_m);
  EXPECT_LT(with_ba.rms_m, 0.004);
  EXPECT_GT(ba.local_runs, 0);
  EXPECT_GT(ba.global_runs, 0);
  EXPECT_EQ(ba.refused, 0) << "a healthy adjustment was refused (ba.max_edge_change_*)";
  EXPECT_EQ(graph_only.result->ba.landmarks.landmarks, 0);
}

TEST(MapOptimizer, GlobalBundleAdjustmentsAfterLargeCyclesWaitForTheMapToGrow) {
  const BaSynthScene s = scene();
  // Every loop (2 and 3 keyframes back) counts as a large cycle here; one batch at a time, so no batches
  // coalesce. Without the growth rule each batch with a loop gets a global BA; with it, one only after the
  // map grew by half since the last (k = 2, 3, 5, 8, 12, 18, 27 at most) plus the final requested one.
  const auto span1 = [](MapOptimizerConfig* c) {
    c->ba.global_after_loop_span = 1;
    c->ba.global_min_growth_fraction = 0.0;
  };
  const auto span1_grow = [](MapOptimizerConfig* c) {
    c->ba.global_after_loop_span = 1;
    c->ba.global_min_growth_fraction = 0.5;
  };
  const Outcome every = runScene(s, true, false, span1, true);
  const Outcome grown = runScene(s, true, false, span1_grow, true);
  ASSERT_TRUE(every.result && grown.result);
  std::printf(
      "[ measured ] global BAs: %lld after every large cycle, %lld with the growth rule; rms %.5f / %.5f m\n",
      static_cast<long long>(every.result->ba.global_runs),
      static_cast<long long>(grown.result->ba.global_runs), every.rms_m, grown.rms_m);
  EXPECT_GE(every.result->ba.global_runs, kKeyframes - 4);
  EXPECT_LE(grown.result->ba.global_runs, 9);
  EXPECT_GE(grown.result->ba.global_runs, 2);
  EXPECT_LT(grown.rms_m, 0.004);  // the final global BA gives the same accuracy
}

// Issue #15: a map of more keyframes than ba.global_max_keyframes gets no global BA (past ~4,000 they ran
// out of time and were refused while their window grew with the map); those it would have had are counted.
TEST(MapOptimizer, AMapPastTheGlobalLimitGetsNoGlobalBundleAdjustment) {
  const BaSynthScene s = scene();
  const auto grow = [](MapOptimizerConfig* c) {
    c->ba.global_after_loop_span = 1;
    c->ba.global_min_growth_fraction = 0.2;
  };
  const auto limited = [&](MapOptimizerConfig* c) {
    grow(c);
    c->ba.global_max_keyframes = 12;
  };
  const Outcome all = runScene(s, true, false, grow, true);
  const Outcome capped = runScene(s, true, false, limited, true);
  ASSERT_TRUE(all.result && capped.result);
  std::printf(
      "[ measured ] global BAs: %lld without a limit, %lld up to 12 keyframes (%lld skipped, the last "
      "over %d keyframes); rms %.5f / %.5f m\n",
      static_cast<long long>(all.result->ba.global_runs),
      static_cast<long long>(capped.result->ba.global_runs),
      static_cast<long long>(capped.result->ba.global_skipped), capped.result->ba.global_keyframes_last,
      all.rms_m, capped.rms_m);
  EXPECT_EQ(all.result->ba.global_skipped, 0);
  EXPECT_GE(capped.result->ba.global_skipped, 1);
  EXPECT_GE(capped.result->ba.global_runs, 1);
  EXPECT_LT(capped.result->ba.global_runs, all.result->ba.global_runs);
  EXPECT_LE(capped.result->ba.global_keyframes_last, 12);
  EXPECT_GT(all.result->ba.global_keyframes_last, 12);
}

// Issue #15: a global BA that ends at its time limit without lowering the error (in the fleet run: 9,600
// keyframes under the observation cap, rms 1.15 px before and after, 3 s each) doubles the growth its map
// must reach before the next one; one that helps resets it.
TEST(MapOptimizer, GlobalBundleAdjustmentsThatGainNothingBackOff) {
  const BaSynthScene s = scene();
  const auto grow = [](MapOptimizerConfig* c) {
    c->ba.global_after_loop_span = 1;
    c->ba.global_min_growth_fraction = 0.2;
  };
  const auto grow_no_time = [&](MapOptimizerConfig* c) {
    grow(c);
    c->ba.landmarks.global_max_time_s = 1e-9;  // every global BA stops at once, gaining nothing
  };
  const Outcome helped = runScene(s, true, false, grow, true);
  const Outcome fruitless = runScene(s, true, false, grow_no_time, true);
  ASSERT_TRUE(helped.result && fruitless.result);
  std::printf("[ measured ] global BAs: %lld that help, %lld that gain nothing (%lld counted fruitless)\n",
              static_cast<long long>(helped.result->ba.global_runs),
              static_cast<long long>(fruitless.result->ba.global_runs),
              static_cast<long long>(fruitless.result->ba.global_fruitless));
  EXPECT_EQ(helped.result->ba.global_fruitless, 0);
  EXPECT_GE(fruitless.result->ba.global_fruitless, 2);
  EXPECT_LT(fruitless.result->ba.global_runs, helped.result->ba.global_runs);
}

TEST(MapOptimizer, AFalseLoopNeverEntersTheTracks) {
  const BaSynthScene s = scene();
  const Outcome clean = runScene(s, true, false);
  const Outcome dirty = runScene(s, true, true);
  ASSERT_TRUE(clean.result && dirty.result);
  const auto& disabled = dirty.result->graph.disabled_edges;
  std::printf(
      "[ measured ] false loop: rms %.5f m (clean %.5f m), %zu edge(s) disabled, %lld edges in tracks "
      "(clean %lld)\n",
      dirty.rms_m, clean.rms_m, disabled.size(), static_cast<long long>(dirty.result->ba.edges_in_tracks),
      static_cast<long long>(clean.result->ba.edges_in_tracks));
  ASSERT_EQ(disabled.size(), 1u) << "the false loop was not disabled";
  EXPECT_EQ(dirty.result->ba.edges_in_tracks, clean.result->ba.edges_in_tracks)
      << "the false loop's matches entered the tracks";
  EXPECT_LT(dirty.rms_m, clean.rms_m + 0.001);
}

// Issue #15: an adjustment that would change the relative pose of keyframes sharing landmarks by more than
// ba.max_edge_change_m / _deg is a solve gone wrong and is refused whole. Here the limits are set so low that
// every adjustment is refused: the result is the pose graph's alone.
TEST(MapOptimizer, AnAdjustmentThatMovesCovisibleKeyframesTooFarIsRefused) {
  const BaSynthScene s = scene();
  const Outcome graph_only = runScene(s, false, false);
  const Outcome refused = runScene(s, true, false, [](MapOptimizerConfig* c) {
    c->ba.max_edge_change_m = 1e-6;
    c->ba.max_edge_change_deg = 1e-6;
  });
  ASSERT_TRUE(graph_only.result && refused.result);
  std::printf("[ measured ] rms: pose graph %.5f m, every BA refused %.5f m (%lld refused)\n",
              graph_only.rms_m, refused.rms_m, static_cast<long long>(refused.result->ba.refused));
  EXPECT_GT(refused.result->ba.local_runs, 0);
  EXPECT_GT(refused.result->ba.refused, 0);
  // A local BA can also fail for want of anything to adjust (how keyframes batch depends on timing): none
  // may have been applied.
  EXPECT_EQ(refused.result->ba.local_failures, refused.result->ba.local_runs) << "a local BA was applied";
  EXPECT_EQ(refused.result->ba.global_runs, 0) << "a refused global BA counts as not run";
  EXPECT_NEAR(refused.rms_m, graph_only.rms_m, 0.1 * graph_only.rms_m) << "a refused BA still moved poses";
}

struct GraphRun {
  double rms_m = 0.0;
  int solves = 0, skipped = 0, local = 0, local_refused = 0;
  int local_at_end = 0;  ///< local solves when the last keyframe's result came
  bool settled = false;  ///< a whole-graph solve came by itself once the optimiser was quiet
  std::vector<int64_t> disabled, false_loops;
};

/// Feeds `synth` keyframe by keyframe (pose graph only): each node with the edges that end at it.
/// `settle`: then wait for the optimiser's own result once it has been quiet for ba.global_when_idle_s.
GraphRun feedGraph(const SynthGraph& synth, const MapOptimizerConfig& config, bool settle = false) {
  Collector results;
  GraphRun run;
  run.false_loops = synth.false_edge_ids;
  MapOptimizer optimizer(config, [&](const std::shared_ptr<const MapOptimization>& r) {
    run.solves += r->graph_solved ? 1 : 0;
    results(r);
  });
  uint64_t revision = 0;
  for (const PoseGraphNode& n : synth.graph.nodes()) {
    OptimizerBatch b;
    b.nodes.push_back({n.id, n.robot, n.T_map_kf, n.id == 0});
    for (const PoseGraphEdge& e : synth.graph.edges()) {
      if (std::max(e.from, e.to) != n.id) continue;
      b.edges.push_back(e);
      b.solve = b.solve || e.kind != EdgeKind::kOdometry;
    }
    revision = optimizer.submit(std::move(b));
    results.waitFor(revision);  // one keyframe at a time, as the server's ingest paces them
  }
  auto result = results.waitFor(revision);
  EXPECT_TRUE(result && result->revision >= revision) << "no result";
  if (!result) return run;
  run.local_at_end = result->local_solves;
  if (settle) {  // quiet: the whole-graph solve the neighbourhood solves put off, with a revision of its own
    result = results.waitFor(revision + 1);
    EXPECT_TRUE(result && result->revision > revision) << "no solve when quiet";
    run.settled = result && result->revision > revision && result->graph_solved;
  }
  run.skipped = result->solves_skipped;
  run.local = result->local_solves;
  run.local_refused = result->local_refused;
  run.disabled = result->graph.disabled_edges;
  double sum = 0.0;
  for (size_t i = 0; i < synth.node_ids.size(); ++i)
    sum += (result->graph.T_map_kf.at(synth.node_ids[i]).translation() - synth.T_map_kf_true[i].translation())
               .squaredNorm();
  run.rms_m = std::sqrt(sum / static_cast<double>(synth.node_ids.size()));
  return run;
}

/// Four laps of a circle with exact edges (noise_scale 0) and `false_loops` wrong ones, fed keyframe by
/// keyframe.
GraphRun feedCircle(double solve_above_chi2, int false_loops) {
  SynthGraphConfig c;
  c.keyframes = 400;
  c.keyframes_per_lap = 100;
  c.loop_every = 2;
  c.noise_scale = 0.0;
  c.false_loops = false_loops;
  c.seed = 5;
  MapOptimizerConfig config;
  config.ba.enabled = false;
  config.graph.solve_above_chi2 = solve_above_chi2;
  return feedGraph(makeSynthGraph(c), config);
}

// Issue #15: a loop the estimate already satisfies needs no whole-graph solve (its cost grows with the map);
// one it does not satisfy (here: every false loop) still gets one, and is disabled by it.
TEST(MapOptimizer, OnlyLoopsTheEstimateDoesNotSatisfyGetAWholeGraphSolve) {
  const GraphRun every = feedCircle(0.0, 4);
  const GraphRun gated = feedCircle(PoseGraphConfig{}.solve_above_chi2, 4);
  std::printf(
      "[ measured ] 400-keyframe circle, exact edges, 150 true + %zu false loops: solve after every loop: %d "
      "solves, rms %.4f m; solve_above_chi2 %.2f: %d solves (%d kept without one), rms %.4f m\n",
      gated.false_loops.size(), every.solves, every.rms_m, PoseGraphConfig{}.solve_above_chi2, gated.solves,
      gated.skipped, gated.rms_m);
  ASSERT_EQ(gated.false_loops.size(), 4u);
  EXPECT_EQ(every.skipped, 0);
  EXPECT_GE(every.solves, 150);
  EXPECT_GT(gated.skipped, 100) << "consistent loops were solved for";
  EXPECT_GE(gated.solves, 1) << "false loops must be judged by a solve";
  EXPECT_LE(gated.solves, 8);
  for (int64_t id : gated.false_loops)
    EXPECT_TRUE(std::count(gated.disabled.begin(), gated.disabled.end(), id))
        << "false loop " << id << " kept";
  EXPECT_EQ(gated.disabled.size(), every.disabled.size()) << "the gate changed which loops are kept";
  EXPECT_LT(gated.rms_m, every.rms_m + 0.005);
}

// Issue #15: in a room many passes revisit (every keyframe with loops to 4 earlier passes, noisy edges, 3
// false loops), new loops are solved in their neighbourhood; only what the neighbourhood cannot explain (the
// false loops, drift it cannot absorb) goes to a whole-graph solve, which alone disables loops. Once quiet,
// the optimiser solves the whole graph by itself: same loops kept, same accuracy as solving it every time.
TEST(MapOptimizer, LoopsInARevisitedRoomAreSolvedInTheirNeighbourhood) {
  SynthGraphConfig c = revisitedRoom(46 * 6, 4, 11);
  c.false_loops = 3;
  const SynthGraph synth = makeSynthGraph(c);
  MapOptimizerConfig config;
  config.ba.enabled = false;
  config.graph.local_max_nodes = 0;
  const GraphRun whole = feedGraph(synth, config);
  config.graph.local_max_nodes = 100;
  config.ba.global_when_idle_s = 0.2;
  const GraphRun local = feedGraph(synth, config, true);
  std::printf(
      "[ measured ] %d keyframes, %zu loops (%zu false): whole graph only: %d solves, rms %.4f m, %zu "
      "disabled; "
      "local first (100 nodes): %d solves of which %d local (%d refused), then one when quiet: rms %.4f m, "
      "%zu "
      "disabled\n",
      c.keyframes, synth.loop_edge_ids.size(), synth.false_edge_ids.size(), whole.solves, whole.rms_m,
      whole.disabled.size(), local.solves, local.local, local.local_refused, local.rms_m,
      local.disabled.size());
  EXPECT_EQ(whole.local, 0);
  EXPECT_GT(local.local, 0) << "no neighbourhood solve was kept";
  EXPECT_LT(local.solves - local.local, whole.solves) << "as many whole-graph solves as without";
  EXPECT_GE(local.local_refused, 1) << "the false loops must go to the whole graph";
  for (const GraphRun* run : {&whole, &local})
    for (int64_t id : synth.false_edge_ids)
      EXPECT_TRUE(std::count(run->disabled.begin(), run->disabled.end(), id))
          << "false loop " << id << " kept";
  EXPECT_LE(local.disabled.size(), whole.disabled.size() + 2) << "true loops disabled";
  EXPECT_TRUE(local.settled);
  EXPECT_LT(local.rms_m, whole.rms_m + 0.002) << "after the whole-graph solve when quiet";
}

struct MergeRun {
  std::shared_ptr<const MapOptimization> result;
  int solves = 0;
  double max_error_m = 0.0;  ///< the new chain's keyframes against the truth
  std::vector<int64_t> wrong_edges;
};

/// A 400-keyframe circle (robot 0, exact edges, solved once), then a new chain of 10 keyframes that starts in
/// a frame of its own (5 m and 90 degrees off) and meets the circle through inter-robot edges from its first
/// keyframe; `wrong` of those edges are 1 m off.
MergeRun mergeChain(int wrong) {
  SynthGraphConfig c;
  c.keyframes = 400;
  c.keyframes_per_lap = 100;
  c.loop_every = 2;
  c.noise_scale = 0.0;
  c.seed = 5;
  const SynthGraph synth = makeSynthGraph(c);
  MapOptimizerConfig config;
  config.ba.enabled = false;
  Collector results;
  MergeRun run;
  MapOptimizer optimizer(config, [&](const std::shared_ptr<const MapOptimization>& r) {
    run.solves += r->graph_solved ? 1 : 0;
    results(r);
  });
  OptimizerBatch first;
  for (const PoseGraphNode& n : synth.graph.nodes())
    first.nodes.push_back({n.id, n.robot, n.T_map_kf, n.id == 0});
  first.edges = synth.graph.edges();
  first.solve = true;
  results.waitFor(optimizer.submit(std::move(first)));
  const int solves_before = run.solves;

  // The chain revisits keyframes 10..19 of the first lap; its own frame is T_off away from the map's.
  const SE3 T_off = se3::exp((Vec6() << 5.0, -2.0, 0.3, 0.0, 0.0, M_PI / 2).finished());
  int64_t edge_id = synth.next_edge_id + 1000;
  OptimizerBatch b;
  std::vector<std::pair<int64_t, SE3>> truth;
  for (int k = 0; k < 10; ++k) {
    const int64_t id = 10000 + k;
    const SE3& T_true = synth.T_map_kf_true[10 + k];
    truth.emplace_back(id, T_true);
    b.nodes.push_back({id, 7, T_off * T_true, false});
    if (k > 0) {
      const SE3& T_prev = synth.T_map_kf_true[9 + k];
      b.edges.push_back(
          edge(edge_id++, id, id - 1, T_true.inverse() * T_prev, EdgeKind::kOdometry, 0.01, 0.01));
    }
  }
  for (int j = 0; j < 3; ++j) {  // the chain's first keyframe sees keyframes 110, 210 and 310 (laps 2-4)
    const int64_t to = synth.node_ids[110 + 100 * j];
    SE3 T_from_to = synth.T_map_kf_true[10].inverse() * synth.T_map_kf_true[110 + 100 * j];
    if (j < wrong) {
      T_from_to = T_from_to * se3::exp((Vec6() << 1.0, 0.0, 0.0, 0.0, 0.0, 0.0).finished());
      run.wrong_edges.push_back(edge_id);
    }
    b.edges.push_back(edge(edge_id++, 10000, to, T_from_to, EdgeKind::kInterRobot, 0.01, 0.01));
  }
  b.solve = true;
  b.merge = true;
  run.result = results.waitFor(optimizer.submit(std::move(b)));
  run.solves -= solves_before;
  if (!run.result) return run;
  for (const auto& [id, T_true] : truth)
    run.max_error_m = std::max(
        run.max_error_m, (run.result->graph.T_map_kf.at(id).translation() - T_true.translation()).norm());
  return run;
}

// Issue #15: a robot's new chain meeting a large map for the first time is moved onto it rigidly; when its
// edges then agree with the map, no whole-graph solve follows. One edge that disagrees still gets a solve
// (which disables it): the rigid move never decides alone.
TEST(MapOptimizer, AChainMeetingALargeMapIsMovedRigidlyAndSolvedOnlyIfItsEdgesDisagree) {
  const MergeRun clean = mergeChain(0);
  const MergeRun wrong = mergeChain(1);
  ASSERT_TRUE(clean.result && wrong.result);
  std::printf(
      "[ measured ] new chain onto a 400-keyframe map: %d solve(s), %d merge(s) aligned, max error %.2e m; "
      "with one wrong edge of three: %d solve(s), %zu edge(s) disabled, max error %.2e m\n",
      clean.solves, clean.result->merges_aligned, clean.max_error_m, wrong.solves,
      wrong.result->graph.disabled_edges.size(), wrong.max_error_m);
  EXPECT_EQ(clean.solves, 0) << "the merge alone explained the edges";
  EXPECT_EQ(clean.result->merges_aligned, 1);
  EXPECT_LT(clean.max_error_m, 1e-6);
  ASSERT_EQ(clean.result->graph.components.size(), 1u) << "one map";
  EXPECT_EQ(wrong.solves, 1);
  EXPECT_EQ(wrong.result->graph.disabled_edges, wrong.wrong_edges);
  EXPECT_LT(wrong.max_error_m, 1e-3);
  EXPECT_EQ(wrong.result->graph.components.size(), 1u);
}

}  // namespace
}  // namespace rgbdmap
