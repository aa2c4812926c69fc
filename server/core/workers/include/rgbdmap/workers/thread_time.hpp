#pragma once
// Time measurements of the server's workers: the calling thread's CPU time and the wall time since a point.
#include <chrono>

namespace rgbdmap {

/// CPU time of the calling thread (ms): what a piece of work costs, whatever else the machine is doing.
double threadCpuMs();
double msSince(std::chrono::steady_clock::time_point t0);

}  // namespace rgbdmap
