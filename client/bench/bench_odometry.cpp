// Odometry benchmark on real frames (../shared/data/tum_fr1_rpy_first250), one core:
//  1. Google Benchmark micro-benchmarks of each stage (extract, match, RANSAC, refine) on frame pairs;
//  2. a whole-sequence run printing median/mean/p90 per stage, frames/s and the ATE.
// Usage: bench_odometry [DATASET_DIR] [google-benchmark flags]
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/vision/matcher.hpp"
#include "rgbdmap/vision/pose_refiner.hpp"
#include "rgbdmap/vision/ransac.hpp"

namespace {
using namespace rgbdmap;

struct Fixture {
  std::vector<RgbdFrame> frames;
  std::vector<FrameFeatures> features;
  CameraIntrinsics camera;
  OdometryConfig config;
};
Fixture* g_fix = nullptr;

std::vector<PointMatch> pairMatches(const FrameFeatures& cur, const FrameFeatures& ref,
                                    const OdometryConfig& c) {
  std::vector<char> mask(ref.size());
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = ref.hasDepth(i);
  return toPointMatches(cur, ref, matchDescriptors(cur.descriptors, ref.descriptors, c.matcher, &mask),
                        c.orb.scale_factor);
}

void BM_Extract(benchmark::State& state) {
  const OrbExtractor extractor(g_fix->config.orb);
  const PinholeCamera cam(g_fix->camera);
  size_t i = 0, n = 0;
  for (auto _ : state) {
    auto f = extractor.extract(g_fix->frames[i++ % g_fix->frames.size()], cam);
    n += f.size();
    benchmark::DoNotOptimize(f);
  }
  state.counters["features"] = benchmark::Counter(double(n), benchmark::Counter::kAvgIterations);
}

void BM_Match(benchmark::State& state) {
  size_t i = 0;
  for (auto _ : state) {
    const size_t k = i++ % (g_fix->features.size() - 1);
    auto m = matchDescriptors(g_fix->features[k + 1].descriptors, g_fix->features[k].descriptors,
                              g_fix->config.matcher);
    benchmark::DoNotOptimize(m);
  }
}

void BM_Ransac(benchmark::State& state) {
  const PinholeCamera cam(g_fix->camera);
  const auto matches = pairMatches(g_fix->features[1], g_fix->features[0], g_fix->config);
  for (auto _ : state) benchmark::DoNotOptimize(ransacRigid(matches, cam, g_fix->config.ransac));
  state.counters["matches"] = double(matches.size());
}

void BM_Refine(benchmark::State& state) {
  const PinholeCamera cam(g_fix->camera);
  const auto matches = pairMatches(g_fix->features[1], g_fix->features[0], g_fix->config);
  const auto init = ransacRigid(matches, cam, g_fix->config.ransac).T_cur_ref;
  for (auto _ : state) benchmark::DoNotOptimize(refinePose(matches, init, cam, g_fix->config.refine));
}

BENCHMARK(BM_Extract)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Match)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Ransac)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Refine)->Unit(benchmark::kMillisecond);

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * v.size()))];
}

void wholeSequence(const TumDataset& dataset, const Fixture& fix) {
  VisualOdometry vo(fix.camera, fix.config);
  Trajectory est;
  std::vector<std::vector<double>> t(5);
  for (size_t i = 0; i < dataset.size(); ++i) {
    const auto frame = dataset.load(i);
    if (!frame) continue;
    const auto r = vo.track(*frame);
    est.push_back({r.timestamp, r.T_odom_cam});
    const double v[5] = {r.times.extract_ms, r.times.match_ms, r.times.ransac_ms, r.times.refine_ms,
                         r.times.total_ms};
    for (int k = 0; k < 5; ++k) t[k].push_back(v[k]);
  }
  const char* names[5] = {"extract", "match", "ransac", "refine", "total"};
  std::printf("\nwhole sequence (%zu frames, %zu keyframes, %d losses), ms per frame on one core:\n",
              est.size(), vo.keyframes().size(), vo.trackingLosses());
  std::printf("%-8s %8s %8s %8s\n", "stage", "median", "mean", "p90");
  for (int k = 0; k < 5; ++k) {
    double mean = 0;
    for (double x : t[k]) mean += x / t[k].size();
    std::printf("%-8s %8.2f %8.2f %8.2f\n", names[k], percentile(t[k], 0.5), mean, percentile(t[k], 0.9));
  }
  std::printf("frames/s (median): %.1f\n", 1000.0 / percentile(t[4], 0.5));
  if (dataset.groundTruth())
    if (auto ate = computeAte(*dataset.groundTruth(), est)) std::printf("ATE RMSE: %.4f m\n", ate->rmse);
}

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // the client's budget is one core
  std::string dir = std::string(RGBDMAP_SHARED_DATA_DIR) + "/tum_fr1_rpy_first250";
  if (argc > 1 && argv[1][0] != '-') {
    dir = argv[1];
    --argc;
    ++argv;
  }
  const auto dataset = TumDataset::open(dir);
  if (!dataset) {
    std::printf("bench_odometry: skipped, no dataset (%s)\n", dataset.error().c_str());
    return 0;
  }
  Fixture fix;
  const PinholeCamera cam(fix.camera);
  const OrbExtractor extractor(fix.config.orb);
  for (size_t i = 0; i < std::min<size_t>(40, dataset->size()); ++i) {
    auto f = dataset->load(i);
    if (!f) continue;
    fix.features.push_back(extractor.extract(*f, cam));
    fix.frames.push_back(std::move(*f));
  }
  g_fix = &fix;
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  wholeSequence(*dataset, fix);
  return 0;
}
