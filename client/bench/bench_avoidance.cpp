// Cost of one avoidance update (corridor scan of the latest slice + state machine) on slices of growing
// size, with a wall across the corridor. Prints numbers; asserts nothing.
#include <benchmark/benchmark.h>

#include "rgbdmap/client/avoidance.hpp"

namespace rgbdmap {
namespace {

void BM_AvoidanceUpdate(benchmark::State& state) {
  const double side_m = static_cast<double>(state.range(0)), res = 0.05;
  msg::OccupancySlice s;
  s.resolution_m = static_cast<float>(res);
  s.width = s.height = static_cast<int>(side_m / res);
  s.cells.assign(static_cast<size_t>(s.width) * s.height, msg::OccupancySlice::kFree);
  // Grid x = map z (forward), y = -map x (left), z = -map y (up); centred on the camera at the origin.
  s.T_map_grid.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  s.T_map_grid.translation() = s.T_map_grid.linear() * Vec3(-side_m / 2, -side_m / 2, 0);
  for (int row = 0; row < s.height; ++row)
    s.cells[static_cast<size_t>(row) * s.width + s.width / 2 + 20] = 100;
  s.header.utime = 1000000000;
  AvoidanceController controller{AvoidanceConfig{}};
  double t = 1000.0;
  for (auto _ : state) benchmark::DoNotOptimize(controller.update(s, SE3::Identity(), t));
  state.counters["cells"] = static_cast<double>(s.cells.size());
}
BENCHMARK(BM_AvoidanceUpdate)->Arg(4)->Arg(10)->Arg(50)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rgbdmap

BENCHMARK_MAIN();
