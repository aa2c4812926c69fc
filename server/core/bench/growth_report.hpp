#pragma once
// bench_map_growth's report after the run: the server's totals (loop search, features, landmark tracks,
// memory trims), the map worker's, the accuracy of each lap against the truth and every loop against it.
#include <string>
#include <vector>

#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/server/map_server.hpp"

namespace rgbdmap::bench {

/// Loop search, keyframe features, landmark tracks and memory trims of the run.
void printServerTotals(const MapServerStats& l);
/// The map worker's octree insertion, slices, map updates and memory.
void printMapWorker(const MapServerStats& m);
/// Each lap's ATE (aligned on its own): the mean over the first and the last tenth of the laps, the worst.
void printLapAte(const Trajectory& truth, const Trajectory& estimate, int per_lap,
                 const std::vector<int>& plan);
/// Every loop of the server against the truth: false ones (off by > 5 cm or 2 deg) still enabled, true
/// ones disabled.
void printLoopsAgainstTruth(const MapServer& server, const Trajectory& truth, int per_lap,
                            const std::vector<int>& plan);

}  // namespace rgbdmap::bench
