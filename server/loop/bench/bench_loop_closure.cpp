// Loop closure ingest time per keyframe (retrieval words + query + insert, candidate selection and
// verification), one core. Sequence: two laps of the synthetic loop (150 poses each, a keyframe per pose,
// the second lap re-rendered with other sensor noise so it revisits every place): 300 keyframes.
// Second benchmark: retrieval alone (query + insert) with 1,000 keyframes of ~1,000 features.
#include <algorithm>
#include <ctime>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include "rgbdmap/loop/loop_detector.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap {
namespace {

constexpr int kPosesPerLap = 150;

struct Sequence {
  CameraIntrinsics camera;
  std::vector<FrameFeatures> features;
  std::vector<SE3> T_world_cam;
};

const Sequence& sequence() {
  static const Sequence seq = [] {
    Sequence s;
    SynthConfig cfg;
    cfg.frames = kPosesPerLap;
    const auto scene = SyntheticScene::build(cfg);
    if (!scene) return s;
    s.camera = cfg.camera;
    const OrbExtractor extractor(OrbConfig{});
    for (int lap = 0; lap < 2; ++lap)
      for (int i = 0; i < kPosesPerLap; ++i) {
        const SE3& T = scene->trajectory()[static_cast<size_t>(i)].T_world_cam;
        s.features.push_back(
            extractor.extract(scene->render(T, i + lap * 100000), PinholeCamera(cfg.camera)));
        s.T_world_cam.push_back(T);
      }
    return s;
  }();
  return seq;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

void BM_IngestKeyframe(benchmark::State& state) {
  cv::setNumThreads(1);
  const Sequence& seq = sequence();
  std::vector<double> ms, cpu_ms;
  double edges = 0, candidates = 0;
  for (auto _ : state) {
    LoopDetector detector(seq.camera);
    ms.clear();
    cpu_ms.clear();
    for (size_t k = 0; k < seq.features.size(); ++k) {
      SE3 T_map_kf = seq.T_world_cam[k];
      T_map_kf.translation().x() += 0.002 * static_cast<double>(k);  // odometry-like drift
      const std::clock_t c0 = std::clock();
      auto r = detector.addKeyframe({static_cast<int>(k), 0, 0, T_map_kf, seq.features[k]});
      if (!r) state.SkipWithError(r.error().c_str());
      if (!r) break;
      ms.push_back(r->stats.total_ms);
      cpu_ms.push_back(1000.0 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
      edges += static_cast<double>(r->edges.size());
      candidates += r->stats.candidates;
    }
  }
  const double n = static_cast<double>(state.iterations()) * static_cast<double>(seq.features.size());
  state.counters["keyframes"] = static_cast<double>(seq.features.size());
  state.counters["median_ms"] = percentile(ms, 0.5);
  state.counters["p90_ms"] = percentile(ms, 0.9);
  state.counters["max_ms"] = percentile(ms, 1.0);
  // Process CPU time (single-threaded): the cost without other processes on the same core.
  state.counters["cpu_median_ms"] = percentile(cpu_ms, 0.5);
  state.counters["cpu_p90_ms"] = percentile(cpu_ms, 0.9);
  state.counters["candidates_per_kf"] = candidates / n;
  state.counters["edges_per_kf"] = edges / n;
}
BENCHMARK(BM_IngestKeyframe)->Unit(benchmark::kMillisecond)->Iterations(1);

/// Words + query + insert per iteration, starting from an index of 1,000 keyframes (the sequence's
/// keyframes repeated); 500 iterations leave it at 1,500, so the number is slightly pessimistic.
void BM_RetrievalWordsQueryInsert(benchmark::State& state) {
  const Sequence& seq = sequence();
  const BinaryWordHasher hasher;
  BinaryWordIndex index;
  for (int i = 0; i < 1000; ++i)
    index.insert(i, 0, i,
                 hasher.histogram(seq.features[static_cast<size_t>(i) % seq.features.size()].descriptors));
  int next = 1000;
  RetrievalQuery q;
  q.robot_id = 0;
  for (auto _ : state) {
    const WordHistogram w =
        hasher.histogram(seq.features[static_cast<size_t>(next) % seq.features.size()].descriptors);
    q.robot_sequence = next;
    benchmark::DoNotOptimize(index.query(w, q));
    index.insert(next, 0, next, w);
    ++next;
  }
  state.counters["features_per_kf"] = static_cast<double>(seq.features[0].size());
}
BENCHMARK(BM_RetrievalWordsQueryInsert)->Unit(benchmark::kMicrosecond)->Iterations(500);

}  // namespace
}  // namespace rgbdmap

BENCHMARK_MAIN();
