// rgbdmap odometry: visual odometry over a frame source (TUM folder, bag, camera); writes a pose per frame
// and the keyframes.
#include <cstdio>

#include <opencv2/core.hpp>

#include "commands.hpp"
#include "odometry_runner.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/source_setup.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kOdometryUsage =
    "usage: rgbdmap odometry (--dataset DIR | --source URL) --out traj.txt [options]\n"
    "  --dataset DIR           TUM layout: rgb.txt, depth.txt, rgb/, depth/ [, groundtruth.txt, "
    "camera.yaml];\n"
    "                          a 7-Scenes sequence folder reads as --source 7scenes:DIR\n"
    "  --out FILE              trajectory, TUM format, one pose per frame; keyframes go to FILE's\n"
    "                          stem + .keyframes.txt\n"
    "  --frames N              only the first N frames\n"
    "  --threads N             OpenCV threads (default 1: the per-core figure a robot budget needs)\n";

std::string keyframesPath(const std::string& out) {
  const auto dot = out.rfind('.');
  const auto slash = out.rfind('/');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash);
  return (has_ext ? out.substr(0, dot) : out) + ".keyframes.txt";
}

}  // namespace

int odometry(int argc, char** argv) {
  cli::Args args(argc, argv, {"help"});
  if (args.has("help")) {
    std::printf("%s%s%s", kOdometryUsage, app::sourceOptionsHelp(), app::datasetOptionsHelp());
    return 0;
  }
  auto allowed = app::datasetOptionNames();
  allowed.insert(allowed.end(), {"dataset", "source", "out", "frames", "threads"});
  args.checkAllowed(allowed);
  std::vector<std::string> errors;
  const auto url = app::sourceUrlArgument(args, &errors, true);
  const auto out = args.get("out");
  if (!out) errors.push_back("--out is required");
  const long long frames = args.getInt("frames").value_or(0);
  const long long threads = args.getInt("threads").value_or(1);
  if (frames < 0) errors.push_back("--frames must be >= 0");
  if (threads < 1 || threads > 256) errors.push_back("--threads must be in [1, 256]");
  cli::applyLogLevel(args, &errors);
  if (!errors.empty() || !args.errors().empty()) app::addConfigErrors(args, url, &errors);
  errors.insert(errors.begin(), args.errors().begin(), args.errors().end());
  if (!errors.empty() || !url) return cli::usageError(errors, kOdometryUsage);
  auto opened = app::openSource(args, *url, {0, frames > 0 ? frames : -1}, &errors);
  if (!errors.empty()) return cli::usageError(errors, kOdometryUsage);
  if (!opened) {
    log::error(opened.error());
    return 1;
  }
  cv::setNumThreads(static_cast<int>(threads));
  const app::OdometrySetup& setup = opened->setup;
  log::info("frames from ", opened->source->describe());
  log::info("camera from ", setup.camera_source, ": fx ", setup.camera.fx, " fy ", setup.camera.fy, " cx ",
            setup.camera.cx, " cy ", setup.camera.cy, " depth_scale ", setup.camera.depth_scale);
  logConfiguration("configuration in effect", setup.effective, defaultOdometryFileValues());
  const app::OdometryRun run = app::runOdometry(*opened->source, setup);
  if (!run.source_error.empty()) log::error(run.source_error);
  if (run.frames == 0) {  // unreadable frames are skipped and counted; with none readable there is no result
    log::error(opened->source->describe(), ": none of the ", run.unreadable_frames, " frames could be read");
    return 1;
  }
  for (const auto& [path, traj, what] :
       {std::tuple{*out, &run.trajectory, "odometry poses, one per frame (T_odom_cam)"},
        std::tuple{keyframesPath(*out), &run.keyframes, "keyframe poses in creation order (T_odom_cam)"}}) {
    const Status s = writeTumTrajectory(path, *traj, what);
    if (!s) {
      log::error(s.error());
      return 1;
    }
  }
  std::fprintf(stderr, "%s\nwrote %s and %s\n", run.summary().c_str(), out->c_str(),
               keyframesPath(*out).c_str());
  return run.source_error.empty() ? 0 : 1;  // what was read is written; a failed source is still an error
}

}  // namespace rgbdmap::cmd
