// rgbdmap run: the main job. Today: odometry on a dataset (synthesised when none is given), evaluated
// against ground truth when there is one, with per-robot outputs and report.json. The mapping server
// (loop closure, global optimisation, merged maps) joins this command with issue #4.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/core.hpp>

#include "cli.hpp"
#include "commands.hpp"
#include "odometry_runner.hpp"
#include "rgbdmap/common/evaluation.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/synth.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kUsage =
    "usage: rgbdmap run [--dataset DIR] [--out DIR] [options]\n"
    "  --dataset DIR           TUM-layout dataset; without it a synthetic sequence is generated first\n"
    "  --out DIR               output folder (default: out)\n"
    "  --scene loop|sweep      synthetic scene when no dataset is given (default loop)\n"
    "  --frames N              synthetic frame count (default 300), or the first N frames of --dataset\n"
    "  --seed S                synthetic seed (default 1)\n"
    "  --threads N             OpenCV threads (default 1)\n";

const char* kRobot = "robot0";

struct RunOptions {
  std::string dataset, out = "out", scene = "loop";
  long long frames = 0, seed = 1, threads = 1;
};

RunOptions parseRunOptions(cli::Args& args, std::vector<std::string>* errors) {
  RunOptions o;
  o.dataset = args.getOr("dataset", "");
  o.out = args.getOr("out", o.out);
  o.scene = args.getOr("scene", o.scene);
  o.frames = args.getInt("frames").value_or(0);
  o.seed = args.getInt("seed").value_or(1);
  o.threads = args.getInt("threads").value_or(1);
  if (o.scene != "loop" && o.scene != "sweep") errors->push_back("--scene must be loop or sweep");
  if (o.frames < 0 || o.frames > 100000) errors->push_back("--frames must be in [0, 100000]");
  if (o.threads < 1 || o.threads > 256) errors->push_back("--threads must be in [1, 256]");
  if (!o.dataset.empty() && (args.has("scene") || args.has("seed")))
    errors->push_back("--scene and --seed only apply without --dataset");
  return o;
}

// Writes a synthetic sequence into OUT/synthetic_<scene> and returns its path (empty on failure).
std::string synthesize(const RunOptions& o) {
  SynthConfig cfg;
  cfg.scene = o.scene;
  cfg.frames = o.frames > 0 ? static_cast<int>(o.frames) : cfg.frames;
  cfg.seed = static_cast<uint64_t>(o.seed);
  const std::string dir = o.out + "/synthetic_" + o.scene;
  log::info("no --dataset: synthesising ", cfg.frames, " frames of the '", o.scene, "' scene into ", dir);
  const Status s = writeSyntheticSequence(cfg, dir);
  if (!s) {
    log::error("synthesis failed: ", s.error());
    return "";
  }
  return dir;
}

std::string reportJson(const std::string& dataset, const app::OdometryRun& run, const AteResult* ate,
                       const RpeResult* rpe) {
  char buf[2048];
  std::snprintf(buf, sizeof buf,
                "{\n  \"mode\": \"odometry_only\",\n  \"dataset\": \"%s\",\n  \"robots\": {\n    \"%s\": {\n"
                "      \"frames\": %d,\n      \"keyframes\": %d,\n      \"tracking_losses\": %d,\n"
                "      \"segments\": %d,\n      \"client_ms_per_frame_median\": %.3f,\n"
                "      \"client_ms_per_frame_mean\": %.3f,\n      \"ate_rmse_m\": %s,\n"
                "      \"rpe_trans_rmse_m\": %s,\n      \"rpe_rot_rmse_deg\": %s\n    }\n  }\n}\n",
                dataset.c_str(), kRobot, run.frames, run.keyframe_count, run.losses, run.segments,
                run.medianMs(&StageTimes::total_ms), run.meanMs(&StageTimes::total_ms),
                ate ? std::to_string(ate->rmse).c_str() : "null",
                rpe ? std::to_string(rpe->trans_rmse).c_str() : "null",
                rpe ? std::to_string(rpe->rot_rmse_deg).c_str() : "null");
  return buf;
}

}  // namespace

int run(int argc, char** argv) {
  cli::Args args(argc, argv, {"help"});
  if (args.has("help")) {
    std::printf("%s%s", kUsage, app::datasetOptionsHelp());
    return 0;
  }
  auto allowed = app::datasetOptionNames();
  allowed.insert(allowed.end(), {"dataset", "out", "scene", "frames", "seed", "threads"});
  args.checkAllowed(allowed);
  std::vector<std::string> errors;
  RunOptions o = parseRunOptions(args, &errors);
  app::applyLogLevel(args, &errors);
  errors.insert(errors.begin(), args.errors().begin(), args.errors().end());
  if (!errors.empty()) return cli::usageError(errors, kUsage);

  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) {
    log::error("cannot create ", o.out, ": ", ec.message());
    return 1;
  }
  cv::setNumThreads(static_cast<int>(o.threads));
  const bool synthetic = o.dataset.empty();
  if (synthetic && (o.dataset = synthesize(o)).empty()) return 1;
  const app::OdometrySetup setup = app::loadOdometrySetup(args, o.dataset, &errors);
  if (!errors.empty()) return cli::usageError(errors, kUsage);
  const auto dataset = TumDataset::open(o.dataset, setup.dataset);
  if (!dataset) {
    log::error(dataset.error());
    return 1;
  }
  const app::OdometryRun run = app::runOdometry(*dataset, setup, synthetic ? 0 : static_cast<int>(o.frames));
  const std::string traj_path = o.out + "/trajectory_" + kRobot + ".txt";
  const std::string kf_path = o.out + "/keyframes_" + kRobot + ".txt";
  for (const auto& [path, traj] :
       {std::pair{traj_path, &run.trajectory}, std::pair{kf_path, &run.keyframes}}) {
    if (const Status s = writeTumTrajectory(path, *traj, "rgbdmap run, robot0, odometry frame"); !s) {
      log::error(s.error());
      return 1;
    }
  }
  std::optional<AteResult> ate;
  std::optional<RpeResult> rpe;
  if (dataset->groundTruth()) {
    if (auto a = computeAte(*dataset->groundTruth(), run.trajectory))
      ate = *a;
    else
      log::warn("ATE: ", a.error());
    if (auto r = computeRpe(*dataset->groundTruth(), run.trajectory))
      rpe = *r;
    else
      log::warn("RPE: ", r.error());
  }
  std::ofstream(o.out + "/report.json")
      << reportJson(o.dataset, run, ate ? &*ate : nullptr, rpe ? &*rpe : nullptr);
  std::fprintf(stderr, "%s\n", run.summary().c_str());
  if (ate) std::fprintf(stderr, "ATE RMSE %.4f m over %zu poses\n", ate->rmse, ate->matched);
  std::fprintf(stderr, "wrote %s, %s, %s/report.json\n", traj_path.c_str(), kf_path.c_str(), o.out.c_str());
  return 0;
}

}  // namespace rgbdmap::cmd
