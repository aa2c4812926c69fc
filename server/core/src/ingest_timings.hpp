#pragma once
// The workers' time measurements under the name map_optimizer.cpp includes them by.
#include "rgbdmap/workers/thread_time.hpp"
