// bench_pose_graph: pose-graph optimisation times on one core.
// - BM_PoseGraph1000Kf200Loops*: 5 laps of a 200-keyframe circle (radius 8 m, height and pitch waves);
//   odometry has 1 cm / 0.23 deg (0.004 rad) noise per axis and edge and initialises the poses (drift of
//   metres after five laps); every 4th keyframe after the first lap closes a loop to the same place one lap
//   earlier. Target: <= 150 ms.
// - BM_PoseGraphFleetRoom*: a room revisited by a fleet (~10 loops per keyframe): the whole graph solved vs.
//   a new keyframe's neighbourhood (what the server's optimiser does).
//   taskset -c 1 build/bin/bench_pose_graph
#include <benchmark/benchmark.h>

#include <algorithm>
#include <fstream>
#include <string>

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
/// The long circle forced onto conjugate gradients: a sparse graph with long chains, ill conditioned for
/// CG with the block Jacobi preconditioner (arg 0); arg 1: the fallback to the spanning tree (the default).
void BM_PoseGraph1000Kf200LoopsCg(benchmark::State& state) {
  rgbdmap::PoseGraphConfig config;
  config.iterative_min_edges_per_node = 0.5;
  config.iterative_tree_fallback = state.range(0) == 1;
  run(state, config, 0);
}

/// A room revisited by a fleet (revisitedRoom): up to 10 loops per keyframe, as the 16-robot fleet run has
/// ~10. `exact_start`: the poses start at the truth (a solved map).
rgbdmap::SynthGraph fleetRoom(int keyframes, bool exact_start) {
  rgbdmap::SynthGraphConfig c = rgbdmap::revisitedRoom(keyframes, 10, 7);
  c.initial_from_odometry = !exact_start;
  rgbdmap::SynthGraph synth = rgbdmap::makeSynthGraph(c);
  synth.graph.setFixed(0);
  return synth;
}

// The whole graph from odometry (2 s cap per solve; conjugate gradients on a graph this dense). Second
// argument: 0 sparse Cholesky, 1 CG with block Jacobi only, 2 CG with the fallback to the spanning tree (the
// default).
void BM_PoseGraphFleetRoom(benchmark::State& state) {
  const rgbdmap::SynthGraph synth = fleetRoom(static_cast<int>(state.range(0)), false);
  rgbdmap::PoseGraphConfig config;
  if (state.range(1) == 0) config.iterative_min_edges_per_node = 0.0;
  config.iterative_tree_fallback = state.range(1) == 2;
  rgbdmap::OptimizeReport report;
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
    state.counters["ate_m"] = rgbdmap::translationRmse(graph, synth);
    state.ResumeTiming();
  }
  state.counters["loops"] = report.loops_total;
  state.counters["solves"] = report.solves;
  state.counters["iterations"] = report.iterations;
  state.counters["out_of_time"] = report.out_of_time ? 1 : 0;
}

/// A field of /proc/self/status in MiB: "VmRSS:" (now) or "VmHWM:" (the peak since the last resetPeak()).
double statusMiB(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind(field, 0) == 0) return std::stod(line.substr(field.size())) / 1024.0;
  return 0.0;
}
/// Sets the peak RSS (VmHWM) to the current RSS.
void resetPeak() { std::ofstream("/proc/self/clear_refs") << "5"; }

// Memory of the whole-graph solve a quiet server runs after a long fleet hour: N keyframes in a revisited
// room with up to `loops` loops per keyframe (bench_map_growth's 20,000-keyframe map has ~4.3 loops per
// keyframe), from the solved poses a little disturbed (what the optimiser's neighbourhood solves leave).
// Counter peak_mib: the RSS the solve added at its peak (VmHWM after a reset, less the RSS before it).
void BM_PoseGraphFleetRoomMemory(benchmark::State& state) {
  rgbdmap::SynthGraphConfig c =
      rgbdmap::revisitedRoom(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), 7);
  c.initial_from_odometry = state.range(2) == 1;
  rgbdmap::SynthGraph synth = rgbdmap::makeSynthGraph(c);
  synth.graph.setFixed(0);
  rgbdmap::PoseGraphConfig config;
  rgbdmap::OptimizeReport report;
  double peak = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    rgbdmap::PoseGraph graph = synth.graph;
    resetPeak();
    const double before = statusMiB("VmRSS:");
    state.ResumeTiming();
    auto result = graph.optimize(config);
    state.PauseTiming();
    peak = std::max(peak, statusMiB("VmHWM:") - before);
    state.ResumeTiming();
    if (!result.ok()) {
      state.SkipWithError(result.error().c_str());
      return;
    }
    report = *result;
  }
  state.counters["nodes"] = static_cast<double>(synth.graph.nodes().size());
  state.counters["edges"] = static_cast<double>(synth.graph.edges().size());
  state.counters["peak_mib"] = peak;
  state.counters["iterations"] = report.iterations;
  state.counters["tree"] = report.tree_preconditioned_solves;
}

// What the server's optimiser does instead: a new keyframe 5 cm off with 10 loops, its neighbourhood of 300
// nodes solved (PoseGraph::optimizeLocal), in a solved map of N keyframes. Flat in N but for one pass over
// the edges.
void BM_PoseGraphFleetRoomNewKeyframeLocal(benchmark::State& state) {
  rgbdmap::SynthGraph synth = fleetRoom(static_cast<int>(state.range(0)), true);
  const int64_t last = synth.node_ids.back(), id = last + 1;
  const rgbdmap::SE3 T_true = synth.T_map_kf_true[synth.T_map_kf_true.size() - 46];  // laps are periodic
  rgbdmap::SE3 off = rgbdmap::SE3::Identity();
  off.translation() = rgbdmap::Vec3(0.05, 0.0, 0.0);
  synth.graph.addNode(id, 0, off * T_true);
  std::vector<int64_t> loops;
  auto add = [&](int64_t from, const rgbdmap::SE3& T_from, rgbdmap::EdgeKind kind) {
    rgbdmap::PoseGraphEdge e;
    e.id = synth.next_edge_id++;
    e.from = from;
    e.to = id;
    e.T_from_to = T_from.inverse() * T_true;
    e.information = rgbdmap::diagonalInformation(0.01, 0.004);
    e.kind = kind;
    synth.graph.addEdge(e);
    if (kind != rgbdmap::EdgeKind::kOdometry) loops.push_back(e.id);
  };
  add(last, synth.T_map_kf_true.back(), rgbdmap::EdgeKind::kOdometry);
  for (size_t l = 1; l <= 10; ++l) {
    const size_t k = synth.node_ids.size() - 46 * l;
    add(synth.node_ids[k], synth.T_map_kf_true[k], rgbdmap::EdgeKind::kLoop);
  }
  rgbdmap::LocalOptimizeReport report;
  for (auto _ : state) {
    state.PauseTiming();
    rgbdmap::PoseGraph graph = synth.graph;
    state.ResumeTiming();
    report = graph.optimizeLocal(loops, rgbdmap::PoseGraphConfig{});
    if (!report.accepted) {
      state.SkipWithError("the local solve was refused");
      return;
    }
    state.PauseTiming();
    state.counters["error_m"] = (graph.pose(id)->translation() - T_true.translation()).norm();
    state.ResumeTiming();
  }
  state.counters["region"] = report.region_nodes;
  state.counters["edges"] = report.edges;
  state.counters["iterations"] = report.iterations;
  state.counters["strain_chi2"] = report.worst_strain_chi2;
}

// The loop detector's measured priors for a new keyframe (PoseGraph::measuredPosesNear with the server's
// defaults, 40 hops, at most 4,000 keyframes) in the fleet room of N keyframes, where ~10 loops per keyframe
// make the 40-hop ball the whole room: the cost of the node cap.
void BM_PoseGraphMeasuredPosesNear(benchmark::State& state) {
  const rgbdmap::SynthGraph synth = fleetRoom(static_cast<int>(state.range(0)), true);
  size_t reached = 0;
  for (auto _ : state) {
    const auto near =
        synth.graph.measuredPosesNear(synth.node_ids.back(), 40, static_cast<size_t>(state.range(1)));
    reached = near.size();
    benchmark::DoNotOptimize(near);
  }
  state.counters["reached"] = static_cast<double>(reached);
}

// What the server does with the graph for every optimisation result, on the ingest and optimiser threads:
// its components (maps) and the poses, in the fleet room of N keyframes (~10 loops per keyframe).
void BM_PoseGraphComponents(benchmark::State& state) {
  const rgbdmap::SynthGraph synth = fleetRoom(static_cast<int>(state.range(0)), true);
  for (auto _ : state) benchmark::DoNotOptimize(synth.graph.components());
  state.counters["edges"] = static_cast<double>(synth.graph.edges().size());
}

}  // namespace

BENCHMARK(BM_PoseGraphComponents)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond)->MinTime(0.5);
BENCHMARK(BM_PoseGraphMeasuredPosesNear)
    ->ArgsProduct({{1000, 10000}, {1000, 4000}})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(0.5);
BENCHMARK(BM_PoseGraphFleetRoom)
    ->ArgsProduct({{1000, 3000}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(BM_PoseGraphFleetRoomMemory)
    ->ArgsProduct({{5000, 20000}, {4}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(BM_PoseGraphFleetRoomNewKeyframeLocal)
    ->Arg(1000)
    ->Arg(3000)
    ->Arg(10000)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(1.0);

BENCHMARK(BM_PoseGraph1000Kf200Loops)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PoseGraph1000Kf200LoopsNoConsistencyCheck)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PoseGraph1000Kf200LoopsAutodiff)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PoseGraph1000Kf200Loops20False)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_PoseGraph1000Kf200LoopsCg)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK_MAIN();
