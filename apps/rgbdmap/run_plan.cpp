#include "run_plan.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap::cmd {
namespace {

std::vector<std::string> splitComma(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

void checkRunOptions(const cli::Args& args, const RunOptions& o, std::vector<std::string>* errors) {
  if (o.scene != "loop" && o.scene != "sweep") errors->push_back("--scene must be loop or sweep");
  if (o.frames < 0 || o.frames > 100000) errors->push_back("--frames must be in [0, 100000]");
  if (o.threads < 1 || o.threads > 256) errors->push_back("--threads must be in [1, 256]");
  if (o.robots < 0 || o.robots > 64) errors->push_back("--robots must be in [1, 64]");
  if (!(o.overlap >= 0.0 && o.overlap < 1.0)) errors->push_back("--overlap must be in [0, 1)");
  if (o.datasets.size() > 1 && o.robots != 0 && o.robots != static_cast<long long>(o.datasets.size()))
    errors->push_back("with several datasets, --robots must equal their number (one robot per dataset)");
  if (o.first_frame > 0 && o.datasets.empty() && !args.has("source"))
    errors->push_back("--frames A:B applies to a dataset (a synthetic sequence is made of --frames N)");
  if (!o.datasets.empty() && (args.has("scene") || args.has("seed")))
    errors->push_back("--scene and --seed only apply without --dataset");
}

}  // namespace

RunOptions parseRunOptions(cli::Args& args, std::vector<std::string>* errors) {
  RunOptions o;
  o.datasets = splitComma(args.getOr("dataset", ""));
  o.out = args.getOr("out", o.out);
  o.scene = args.getOr("scene", o.scene);
  o.transport = args.getOr("transport", o.transport);
  o.server_config = args.getOr("server-config", "");
  const std::string frames = args.getOr("frames", "");
  if (const size_t colon = frames.find(':'); colon != std::string::npos) {
    try {
      size_t used_a = 0, used_b = 0;
      o.first_frame = std::stoll(frames.substr(0, colon), &used_a);
      o.frames = std::stoll(frames.substr(colon + 1), &used_b);
      if (used_a != colon || used_b != frames.size() - colon - 1 || o.first_frame < 0 ||
          o.frames <= o.first_frame)
        throw std::invalid_argument(frames);
    } catch (const std::exception&) {
      errors->push_back("--frames A:B needs 0 <= A < B, not '" + frames + "'");
    }
  } else {
    o.frames = args.getInt("frames").value_or(0);
  }
  o.map = args.getOr("map", "");
  o.frozen_map = args.has("frozen-map");
  if (o.frozen_map && o.map.empty()) errors->push_back("--frozen-map needs --map DIR (the stored map)");
  o.seed = args.getInt("seed").value_or(1);
  o.threads = args.getInt("threads").value_or(1);
  o.robots = args.getInt("robots").value_or(0);
  o.overlap = args.getDouble("overlap").value_or(o.overlap);
  o.realtime = args.has("realtime");
  o.async = args.has("async");
  checkRunOptions(args, o, errors);
  if (o.robots == 0) o.robots = std::max<long long>(1, static_cast<long long>(o.datasets.size()));
  return o;
}

std::string transportUrl(const std::string& name) {
  if (name == "memq") return "memq://";
  if (name == "lcm") return "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216";
  if (name == "dds") return "dds://?domain=0";
  return name;
}

std::vector<RobotPlan> planRobots(const RunOptions& o, const std::vector<size_t>& dataset_frames,
                                  bool synthetic) {
  std::vector<RobotPlan> robots(static_cast<size_t>(o.robots));
  for (size_t i = 0; i < robots.size(); ++i) {
    RobotPlan& r = robots[i];
    r.id = "robot" + std::to_string(i);
    auto key = msg::newKey();
    if (!key) throw std::runtime_error(key.error());  // main reports it; never expected
    r.key = *key;
    r.dataset = dataset_frames.size() > 1 ? i : 0;
    const int total = static_cast<int>(dataset_frames[r.dataset]);
    const int frames =
        (!synthetic && o.frames > 0) ? std::min<int>(total, static_cast<int>(o.frames)) : total;
    const int start = synthetic ? 0 : std::min(frames, static_cast<int>(o.first_frame));
    if (dataset_frames.size() > 1 || robots.size() == 1) {
      r.first = start;
      r.end = frames;
    } else {
      const double seg = static_cast<double>(frames - start) / robots.size();
      const int half_overlap = static_cast<int>(std::lround(0.5 * o.overlap * seg));
      r.first = std::max(start, start + static_cast<int>(std::lround(i * seg)) - half_overlap);
      r.end = std::min(frames, start + static_cast<int>(std::lround((i + 1) * seg)) + half_overlap);
    }
  }
  return robots;
}

}  // namespace rgbdmap::cmd
