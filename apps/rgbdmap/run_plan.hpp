#pragma once
// rgbdmap run, step 1 and 2: the command line (RunOptions) and the plan of the robots (which dataset, which
// frames, which id and key each robot gets).
#include <string>
#include <vector>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::cmd {

struct RunOptions {
  std::vector<std::string> datasets;  ///< empty on the command line: a synthetic sequence is generated
  std::string out = "out", scene = "loop", transport = "memq", server_config;
  long long frames = 0, seed = 1, threads = 1, robots = 0;
  long long first_frame = 0;  ///< --frames A:B: the robots' frames start at A (B is `frames`)
  std::string map;            ///< --map DIR: serve this stored map (extended, or with frozen_map not changed)
  bool frozen_map = false;    ///< --frozen-map: every robot localises in --map's map
  double overlap = 0.25;
  bool realtime = false;
  bool async = false;  ///< --async: robots do not wait for the server after each keyframe
};

/// Reads and checks the options of `rgbdmap run`; every problem is appended to *errors.
RunOptions parseRunOptions(cli::Args& args, std::vector<std::string>* errors);

/// memq|lcm|dds|URL -> transport URL.
std::string transportUrl(const std::string& name);

/// One robot of the run.
struct RobotPlan {
  std::string id;          ///< robot0, robot1, ...
  size_t dataset = 0;      ///< index into the run's datasets
  int first = 0, end = 0;  ///< frames [first, end) of that dataset
  msg::Bytes key;          ///< its own random 32-byte key (signed messages, as in a deployment)
};

/// One robot per dataset, or options.robots overlapping segments of the one dataset. `dataset_frames`
/// holds each dataset's frame count; options.frames limits a real dataset (a synthetic one already has it).
std::vector<RobotPlan> planRobots(const RunOptions& options, const std::vector<size_t>& dataset_frames,
                                  bool synthetic);

}  // namespace rgbdmap::cmd
