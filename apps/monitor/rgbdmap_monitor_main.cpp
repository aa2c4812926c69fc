// rgbdmap-monitor: a read-only subscriber that shows what the mapping server is doing. It listens on every
// channel of the given robots: ServerStatus and MapUpdate are authenticated (each robot's copy is signed with
// that robot's key, so the monitor needs the keys file or --open) and decoded, and so is each robot's own
// LinkStatus (signed by the robot: its keyframe spool and oldest unanswered keyframe); the other channels are
// only counted, which gives each robot's bandwidth up (robot -> server) and down (server -> robot).
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <octomap/OcTree.h>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "monitor_view.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/proto/channels.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {
namespace {

const char* kUsage =
    "usage: rgbdmap-monitor --transport URL --robots a,b (--keys-file FILE | --open) [options]\n"
    "Prints the mapping server's status (robots, keyframes, loops, graph revision, bandwidth per robot) and\n"
    "each robot's keyframe spool (keyframes not yet acknowledged, the oldest one's age: its LinkStatus).\n"
    "  --transport URL     udpm://239.255.76.67:7667?ttl=0 | dds://?domain=0 (needs CYCLONEDDS_URI)\n"
    "  --robots a,b,c      robots whose channels to watch (the server signs each robot's copy with its key)\n"
    "  --keys-file FILE    the server's keys file (\"robot_id hexkey\" lines)\n"
    "  --open              accept unsigned messages (server in open mode)\n"
    "  --period S          print every S seconds (default 2)\n"
    "  --save-map DIR      write the latest map stream of each robot to DIR/map_<robot>.bt\n"
    "  --once              print one line and exit once a status came and one period passed (exit 1 if no\n"
    "                      status within --timeout)\n"
    "  --timeout S         give up after S seconds (default 0: run until SIGINT/SIGTERM)\n"
    "  --log-level L       debug|info|warn|error\n"
    "On a terminal the table is redrawn in place; otherwise one line per period.\n";

MonitorOptions parseOptions(cli::Args& args, std::vector<std::string>* errors) {
  MonitorOptions o;
  o.transport_url = args.getOr("transport", "");
  if (o.transport_url.empty())
    errors->push_back("--transport URL is required");
  else if (const Status s = transport::checkTransportUrl(o.transport_url); !s)
    errors->push_back(s.error());
  o.robots = splitList(args.getOr("robots", ""));
  if (o.robots.empty()) errors->push_back("--robots a,b is required");
  o.keys_file = args.getOr("keys-file", "");
  o.open = args.has("open");
  if (o.keys_file.empty() && !o.open) errors->push_back("--keys-file FILE or --open is required");
  o.once = args.has("once");
  o.save_dir = args.getOr("save-map", "");
  o.period_s = args.getDouble("period").value_or(2.0);
  o.timeout_s = args.getDouble("timeout").value_or(0.0);
  for (const std::string& problem : monitorOptionsTable().problems(o)) errors->push_back("--" + problem);
  cli::applyLogLevel(args, errors);
  for (const auto& p : args.positional()) errors->push_back("unexpected argument '" + p + "'");
  return o;
}

int runMonitor(int argc, char** argv) {
  cli::Args args(argc, argv, {"help", "open", "once"});
  if (args.has("help")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  // SIGINT/SIGTERM blocked in every thread (set before any thread starts) and taken by sigwait below.
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGINT, SIGTERM, SIGUSR1}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  args.checkAllowed(
      {"transport", "robots", "keys-file", "open", "period", "save-map", "once", "timeout", "log-level"});
  std::vector<std::string> errors(args.errors().begin(), args.errors().end());
  const MonitorOptions options = parseOptions(args, &errors);
  if (!errors.empty()) return cli::usageError(errors, kUsage);
  logConfiguration("configuration in effect", monitorOptionsTable().values(options),
                   monitorOptionsTable().values({}));

  msg::KeyStore server_keys;
  if (!options.keys_file.empty()) {
    auto read = msg::readKeysFile(options.keys_file);
    if (!read) {
      log::error(read.error());
      return 2;
    }
    server_keys = std::move(*read);
  }
  if (!options.save_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(options.save_dir, ec);
    if (ec) {
      log::error("--save-map ", options.save_dir, ": ", ec.message());
      return 1;
    }
  }
  auto transport = transport::makeTransport(options.transport_url);
  if (!transport) {
    log::error("transport ", options.transport_url, ": ", transport.error());
    return 1;
  }
  Monitor monitor(options);
  if (const Status s = monitor.setup(server_keys, **transport); !s) {
    log::error(s.error());
    return 2;
  }
  if (const Status s = (*transport)->start(); !s) {
    log::error("transport start: ", s.error());
    return 1;
  }
  std::thread signal_thread([&] {
    int sig = 0;
    if (sigwait(&signals, &sig) == 0 && sig != SIGUSR1) monitor.requestStop();
  });
  const int code = monitor.run();
  pthread_kill(signal_thread.native_handle(), SIGUSR1);
  signal_thread.join();
  (*transport)->stop();
  return code;
}

}  // namespace
}  // namespace rgbdmap

int main(int argc, char** argv) { return rgbdmap::runMonitor(argc - 1, argv + 1); }
