// bench_pose_graph: optimisation time of a 1,000-keyframe graph with 200 loop edges on one core.
// The trajectory drives 5 laps of a 200-keyframe circle (radius 8 m, height and pitch waves); odometry has
// 1 cm / 0.23 deg (0.004 rad) noise per axis and edge and initialises the poses (drift of metres after five
// laps); every 4th keyframe after the first lap closes a loop to the same place one lap earlier. Target: <=
// 150 ms.
//   taskset -c 1 build/bin/bench_pose_graph
#include <benchmark/benchmark.h>

#include "rgbdmap/graph/pose_graph_synth.hpp"

namespace {

rgbdmap::SynthGraph benchGraph(int false_loops) {
  rgbdmap::SynthGraphConfig c;
  c.keyframes = 1000;
  c.keyframes_per_lap = 200;
  c.radius_m = 8.0;
  c.loop_every = 4;  // 800 keyframes after the first lap / 4 = 200 loops
  c.false_loops = false_loops;
  c.seed = 7;
  auto synth = rgbdmap::makeSynthGraph(c);
  synth.graph.setFixed(0);
  return synth;
}

void run(benchmark::State& state, const rgbdmap::PoseGraphConfig& config, int false_loops) {
  const rgbdmap::SynthGraph synth = benchGraph(false_loops);
  rgbdmap::OptimizeReport report;
  double rmse = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    rgbdmap::PoseGraph graph = synth.graph;
    state.ResumeTiming();
    auto result = graph.optimize(config);
    if (!result.ok()) {
      state.SkipWithError(result.error().c_str());
      return;
    }
    report = *result;
    state.PauseTiming();
    rmse = rgbdmap::translationRmse(graph, synth);
    state.ResumeTiming();
  }
  state.counters["loops"] = report.loops_total;
  state.counters["rejected"] = report.loops_rejected;
  state.counters["solves"] = report.solves;
  state.counters["iterations"] = report.iterations;
  state.counters["ate_m"] = rmse;
  state.counters["ate_init_m"] = rgbdmap::translationRmse(synth.graph, synth);
}

void BM_PoseGraph1000Kf200Loops(benchmark::State& state) { run(state, rgbdmap::PoseGraphConfig{}, 0); }
void BM_PoseGraph1000Kf200LoopsNoConsistencyCheck(benchmark::State& state) {
  rgbdmap::PoseGraphConfig config;
  config.max_outlier_rounds = 0;
  run(state, config, 0);
}
void BM_PoseGraph1000Kf200LoopsAutodiff(benchmark::State& state) {
  rgbdmap::PoseGraphConfig config;
  config.analytic_jacobians = false;
  run(state, config, 0);
}
void BM_PoseGraph1000Kf200Loops20False(benchmark::State& state) {
  run(state, rgbdmap::PoseGraphConfig{}, 20);
}

}  // namespace

BENCHMARK(BM_PoseGraph1000Kf200Loops)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PoseGraph1000Kf200LoopsNoConsistencyCheck)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PoseGraph1000Kf200LoopsAutodiff)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PoseGraph1000Kf200Loops20False)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_MAIN();
