// rgbdmap eval: ATE and RPE of an estimated trajectory against ground truth (TUM benchmark conventions).
#include <cstdio>
#include <optional>
#include <string>

#include "commands.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/dataset/evaluation_json.hpp"
#include "rgbdmap/dataset/trajectory.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kEvalUsage =
    "usage: rgbdmap eval --gt GROUNDTRUTH --est ESTIMATE [options]\n"
    "Absolute trajectory error (after least-squares alignment) and relative pose error of an estimated\n"
    "trajectory; both files in TUM format (timestamp tx ty tz qx qy qz qw, '#' comments).\n"
    "options:\n"
    "  --gt FILE          ground-truth trajectory, e.g. a TUM groundtruth.txt\n"
    "  --est FILE         estimated trajectory (T_world_cam per line)\n"
    "  --max-dt S         timestamp association tolerance in seconds (default 0.02)\n"
    "  --delta S          RPE pose-pair spacing in seconds (default 1.0)\n"
    "  --scale            align with scale as well (Sim(3), for monocular estimates)\n"
    "  --align-on FILE    align with the alignment of FILE (another estimate in the same frame, e.g. the\n"
    "                     session that made a map) instead of the estimate's own: ATE in that fixed frame\n"
    "  --align-gt FILE    the ground truth of --align-on's estimate when it is another sequence's in the "
    "same\n"
    "                     frame (TUM sequences of one room share the motion-capture frame; default --gt)\n"
    "  --json             print one JSON object instead of `key value` lines\n"
    "  --log-level LEVEL  debug|info|warn|error|off (default warn)\n"
    "  --help             this text\n"
    "exit status: 0 success, 1 unreadable file or evaluation impossible, 2 usage error\n";

struct EvalConfig {
  std::string gt_path;
  std::string est_path;
  std::string align_on_path;  ///< --align-on: the alignment comes from this estimate ...
  std::string align_gt_path;  ///< ... and this ground truth (--align-gt, default gt_path)
  AteOptions ate;
  RpeOptions rpe;
  bool json = false;
};

/// Parses and checks every option; all problems are reported together.
std::optional<EvalConfig> parseConfig(cli::Args& args) {
  args.checkAllowed(
      {"gt", "est", "max-dt", "delta", "scale", "json", "log-level", "help", "align-on", "align-gt"});
  for (const auto& p : args.positional()) args.addError("unexpected argument '" + p + "'");
  EvalConfig c;
  c.gt_path = args.getOr("gt", "");
  c.est_path = args.getOr("est", "");
  c.align_on_path = args.getOr("align-on", "");
  c.align_gt_path = args.getOr("align-gt", c.gt_path);
  if (c.gt_path.empty()) args.addError("--gt is required");
  if (c.est_path.empty()) args.addError("--est is required");
  if (const auto v = args.getDouble("max-dt")) {
    if (*v > 0)
      c.ate.max_dt = c.rpe.max_dt = *v;
    else
      args.addError("--max-dt must be > 0");
  }
  if (const auto v = args.getDouble("delta")) {
    if (*v > 0)
      c.rpe.delta = *v;
    else
      args.addError("--delta must be > 0");
  }
  log::Level level = log::Level::kWarn;
  if (args.has("log-level") && !log::parseLevel(args.getOr("log-level", ""), &level))
    args.addError("--log-level: expected debug|info|warn|error|off");
  log::setLevel(level);
  c.ate.with_scale = args.has("scale");
  c.json = args.has("json");
  if (!args.errors().empty()) return std::nullopt;
  return c;
}

void printJson(const EvalConfig& c, size_t gt_poses, size_t est_poses, const Result<AteResult>& ate,
               const Result<RpeResult>& rpe) {
  Json out = {{"gt", c.gt_path},
              {"est", c.est_path},
              {"gt_poses", gt_poses},
              {"est_poses", est_poses},
              {"max_dt_s", jsonNumber(c.ate.max_dt, 9)},
              {"delta_s", jsonNumber(c.rpe.delta, 9)},
              {"alignment", c.ate.with_scale ? "sim3" : "se3"}};
  out["ate"] = ate ? ateJson(*ate) : Json();
  if (!ate) out["ate_error"] = ate.error();
  out["rpe"] = rpe ? rpeJson(*rpe) : Json();
  if (!rpe) out["rpe_error"] = rpe.error();
  std::printf("%s\n", compactJson(out).c_str());
}

void printText(const EvalConfig& c, size_t gt_poses, size_t est_poses, const Result<AteResult>& ate,
               const Result<RpeResult>& rpe) {
  std::printf("gt_poses %zu\nest_poses %zu\nmax_dt_s %g\nalignment %s\n", gt_poses, est_poses, c.ate.max_dt,
              c.ate.with_scale ? "sim3" : "se3");
  if (ate) std::fputs(formatAte(*ate).c_str(), stdout);
  if (rpe) std::fputs(formatRpe(*rpe).c_str(), stdout);
}

}  // namespace

int eval(int argc, char** argv) {
  cli::Args args(argc, argv, {"scale", "json", "help"});
  if (args.has("help")) {
    std::fputs(kEvalUsage, stdout);
    return 0;
  }
  const std::optional<EvalConfig> config = parseConfig(args);
  if (!config) return cli::usageError(args.errors(), kEvalUsage);
  const auto gt = readTumTrajectory(config->gt_path);
  const auto est = readTumTrajectory(config->est_path);
  if (!gt || !est) {
    if (!gt) std::fprintf(stderr, "rgbdmap eval: %s\n", gt.error().c_str());
    if (!est) std::fprintf(stderr, "rgbdmap eval: %s\n", est.error().c_str());
    return 1;
  }
  log::info("eval: gt ", config->gt_path, " (", gt->size(), " poses), est ", config->est_path, " (",
            est->size(), " poses), max_dt ", config->ate.max_dt, " s, delta ", config->rpe.delta,
            " s, alignment ", config->ate.with_scale ? "sim3" : "se3");
  AteOptions ate_options = config->ate;
  if (!config->align_on_path.empty()) {
    const auto on = readTumTrajectory(config->align_on_path);
    const auto on_gt = readTumTrajectory(config->align_gt_path);
    const Result<AteResult> fixed = !on      ? Result<AteResult>::failure(on.error())
                                    : !on_gt ? Result<AteResult>::failure(on_gt.error())
                                             : computeAte(*on_gt, *on, config->ate);
    if (!fixed) return std::fprintf(stderr, "rgbdmap eval: --align-on: %s\n", fixed.error().c_str()), 1;
    ate_options.fixed_alignment = fixed->T_gt_est;
    ate_options.fixed_scale = fixed->scale;
  }
  const Result<AteResult> ate = computeAte(*gt, *est, ate_options);
  const Result<RpeResult> rpe = computeRpe(*gt, *est, config->rpe);
  if (config->json)
    printJson(*config, gt->size(), est->size(), ate, rpe);
  else
    printText(*config, gt->size(), est->size(), ate, rpe);
  if (!ate) std::fprintf(stderr, "rgbdmap eval: %s\n", ate.error().c_str());
  if (!rpe) std::fprintf(stderr, "rgbdmap eval: %s\n", rpe.error().c_str());
  return ate && rpe ? 0 : 1;
}

}  // namespace rgbdmap::cmd
