#pragma once
// What rgbdmap-client writes into --out: trajectories (TUM format) and client_<robot>.json.
#include <string>

#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/link/robot_runner.hpp"

namespace rgbdmap::app {

struct ClientRunInfo {
  std::string robot_id, dataset, transport_url;
  bool signed_messages = false;
};

/// Writes trajectory_<R>.txt (final_map), trajectory_<R>_live.txt, keyframes_<R>.txt, client_<R>.json.
Status writeClientOutputs(const std::string& out_dir, const ClientRunInfo& info,
                          const RobotRunResult& result);

/// The JSON summary (one object; numbers, counters, flags), written atomically as client_<R>.json.
Json clientJson(const ClientRunInfo& info, const RobotRunResult& result);

/// Human summary for stderr.
std::string clientSummary(const RobotRunResult& result);

}  // namespace rgbdmap::app
