#pragma once
// rgbdmap run, step 5: the outputs. Per robot trajectory_<robot>.txt (every frame, map frame) and
// keyframes_<robot>.txt (the server's optimised keyframes), report.json and a summary on stderr.
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/link/robot_runner.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "run_plan.hpp"

namespace rgbdmap::cmd {

/// What one robot's run produced, with its accuracy against the dataset's ground truth (when it has one).
struct RobotOutcome {
  RobotRunResult result;
  std::optional<AteResult> ate, ate_odometry;
};

/// What the server reported at the end of the run.
struct ServerOutcome {
  MapServerStats stats;
  std::vector<ServerKeyframe> keyframes;
  std::vector<std::vector<std::string>> maps;  ///< robot ids per map
  std::optional<AteResult> joint;  ///< all robots' frames (one dataset) aligned once: only a merge fits
  double wall_s = 0.0;
  double prepare_s = 0.0;    ///< before the run: sources converted, the sequence synthesised, datasets read
  std::string prepare_what;  ///< what that was, for the summary line
};

/// ATE of every robot's final and odometry-only trajectory, and the joint ATE of all robots on one dataset.
void evaluateRun(const std::vector<TumDataset>& datasets, const std::vector<RobotPlan>& plans,
                 std::vector<RobotOutcome>* robots, ServerOutcome* server);

/// trajectory_<robot>.txt and keyframes_<robot>.txt in `out_dir`.
Status writeTrajectories(const std::string& out_dir, const std::vector<RobotPlan>& plans,
                         const std::vector<RobotOutcome>& robots,
                         const std::vector<ServerKeyframe>& keyframes);

/// report.json: mode, transport, datasets, wall_s, the server's counters and maps, per robot its frames,
/// keyframes, acknowledgements, accuracy, timing and traffic.
Json reportJson(const RunOptions& options, const std::vector<RobotPlan>& plans,
                const std::vector<RobotOutcome>& robots, const ServerOutcome& server);

/// The human summary on stderr.
void printRunSummary(const RunOptions& options, const std::string& url, const std::vector<RobotPlan>& plans,
                     const std::vector<RobotOutcome>& robots, const ServerOutcome& server);

}  // namespace rgbdmap::cmd
