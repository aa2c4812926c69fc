// Bundle adjustment cost on one core: local BA against its window size and global BA against the
// map size, on synthetic scenes with exact ground truth (ba_synth.hpp: ~1,000 features a keyframe at the
// default density, tracks from the true matches with the 4 previous keyframes, poses perturbed by 2 cm and
// 0.6 deg). Prints one line per configuration: time (median of repeats), observations, keyframe error.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "rgbdmap/ba/ba_synth.hpp"
#include "rgbdmap/ba/landmark_map.hpp"

namespace rgbdmap {
namespace {

BaSolver g_solver = BaSolver::kSchur;
int g_iterative_min_frames = BaSolveConfig().iterative_min_frames;

struct Built {
  BaSynthScene scene;
  LandmarkMap map;
};

Built build(int keyframes, const LandmarkMapConfig& config, unsigned seed) {
  BaSynthConfig sc;
  sc.keyframes = keyframes;
  sc.step_m = 0.2;            // a point is seen by ~15 keyframes
  sc.turn_rad_per_m = 0.002;  // a long sweep that keeps facing the points (up to 100 m)
  sc.climb_per_m = 0.0;
  sc.roll_rad_per_keyframe = 0.0002;
  sc.points = 1500 + 60 * keyframes;
  sc.seed = seed;
  Built b{makeBaSynthScene(sc), LandmarkMap(config)};
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < keyframes; ++k) {
    SE3 T = b.scene.T_map_kf[k];
    if (k > 0)
      T = T * se3::exp((Vec6() << 0.02 * n(rng), 0.02 * n(rng), 0.02 * n(rng), 0.01 * n(rng), 0.01 * n(rng),
                        0.01 * n(rng))
                           .finished());  // in the keyframe's own frame
    b.map.addKeyframe(synthKeyframe(b.scene, k, T));
    for (int j = std::max(0, k - 4); j < k; ++j) b.map.addMatches(synthTrueMatches(b.scene, k, j));
  }
  return b;
}

double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double rmsError(const Built& b) {
  double sum = 0;
  for (size_t k = 0; k < b.scene.T_map_kf.size(); ++k)
    sum += (b.map.pose(static_cast<int64_t>(k))->translation() - b.scene.T_map_kf[k].translation())
               .squaredNorm();
  return std::sqrt(sum / static_cast<double>(b.scene.T_map_kf.size()));
}

void localBa(int window) {
  LandmarkMapConfig config;
  config.solve.solver = g_solver;
  config.local_window = window;
  std::vector<double> ms, cpu;
  int obs = 0, frames = 0;
  for (int rep = 0; rep < 5; ++rep) {
    Built b = build(60, config, 10 + rep);
    const double cpu0 = threadCpuMs();
    const BundleResult r = b.map.localAdjust(59, 0);
    cpu.push_back(threadCpuMs() - cpu0);
    ms.push_back(r.report.time_ms);
    obs = r.report.observations;
    frames = r.report.frames;
  }
  std::sort(ms.begin(), ms.end());
  std::sort(cpu.begin(), cpu.end());
  std::printf(
      "local BA   window %3d: %7.1f ms CPU median (%.1f ms wall; %d frames incl. fixed, %d observations)\n",
      window, cpu[cpu.size() / 2], ms[ms.size() / 2], frames, obs);
}

void globalBa(int keyframes, bool rolling_shutter) {
  LandmarkMapConfig config;
  config.solve.solver = g_solver;
  config.solve.iterative_min_frames = g_iterative_min_frames;
  config.solve.rolling_shutter = rolling_shutter;
  Built b = build(keyframes, config, 3);
  const double before = rmsError(b);
  const double cpu0 = threadCpuMs();
  const BundleResult r = b.map.globalAdjust(0, 0);
  const double cpu = threadCpuMs() - cpu0;
  std::printf(
      "global BA %4d keyframes%s: %8.1f ms CPU (%.1f ms wall; %d points, %d observations, %d iterations%s; "
      "keyframe rms %.4f -> %.5f m)\n",
      keyframes, rolling_shutter ? "" : " (no rolling shutter)", cpu, r.report.time_ms, r.report.points,
      r.report.observations, r.report.iterations, r.report.out_of_time ? ", OUT OF TIME" : "", before,
      rmsError(b));
}

}  // namespace
}  // namespace rgbdmap

int main(int argc, char** argv) {
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      quick = true;
    } else if (a == "--ceres") {
      rgbdmap::g_solver = rgbdmap::BaSolver::kCeres;
    } else if (a == "--iterative-min-frames" && i + 1 < argc) {
      char* end = nullptr;
      const long n = std::strtol(argv[++i], &end, 10);
      if (*end != '\0' || n < 1 || n > 100000000) {
        std::fprintf(stderr, "--iterative-min-frames takes a whole number in [1, 100000000], not '%s'\n",
                     argv[i]);
        return 2;
      }
      rgbdmap::g_iterative_min_frames = static_cast<int>(n);
    } else {
      std::fprintf(stderr, "usage: bench_bundle_adjustment [--quick] [--ceres] [--iterative-min-frames N]\n");
      return 2;
    }
  }
  std::printf("bundle adjustment, one thread (synthetic, ~1000 features per keyframe), %s solver\n",
              rgbdmap::g_solver == rgbdmap::BaSolver::kCeres ? "Ceres" : "own Schur");
  const rgbdmap::LandmarkMapConfig defaults;
  std::printf(
      "global BA caps: %d observations, %d per landmark, %.1f s per solve; conjugate gradients from %d "
      "frames\n",
      defaults.global_max_observations, defaults.global_max_track, defaults.global_max_time_s,
      rgbdmap::g_iterative_min_frames);
  for (int w : {5, 10, 15, 20}) rgbdmap::localBa(w);
  for (int n : quick ? std::vector<int>{100} : std::vector<int>{100, 250, 500})
    for (bool rs : {true, false}) rgbdmap::globalBa(n, rs);
  return 0;
}
