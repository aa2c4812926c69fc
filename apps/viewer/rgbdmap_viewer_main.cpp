// rgbdmap-viewer: the live map viewer as a program. Subscribes to the map streams of the given robots (like
// rgbdmap-monitor: the server's keys file or --open) and serves them on one HTTP port: Foxglove
// (ws://HOST:PORT, subprotocol foxglove.websocket.v1) and the built-in web page (http://HOST:PORT/).
#include <pthread.h>
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/signal_thread.hpp"
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/transport/transport.hpp"
#include "rgbdmap/viewer/viewer.hpp"

namespace rgbdmap {
namespace {

const char* kUsage =
    "usage: rgbdmap-viewer --transport URL --robots a,b (--keys-file FILE | --open) [options]\n"
    "Serves the live map on one HTTP port: Foxglove WebSocket (ws://HOST:PORT) and a web page "
    "(http://HOST:PORT/).\n"
    "  --transport URL       udpm://239.255.76.67:7667?ttl=0 | dds://?domain=0 (needs CYCLONEDDS_URI)\n"
    "  --robots a,b,c        robots whose map streams to show\n"
    "  --keys-file FILE      the server's keys file (\"robot_id hexkey\" lines)\n"
    "  --open                accept unsigned messages (server in open mode)\n"
    "  --port N              HTTP/WebSocket port (default 8765; 0: any free port, logged)\n"
    "  --bind ADDR           listen address (default 127.0.0.1: this computer only)\n"
    "  --max-clients N       WebSocket clients at once (default 16)\n"
    "  --cloud-period S      at most one point cloud per robot every S seconds (default 1)\n"
    "  --snapshot-period S   full voxel snapshots every S seconds (default 30)\n"
    "  --web-dir DIR         the page's files (default: the installed ones)\n"
    "  --record FILE.mcap    also write every published message (all topics but /R/voxel_delta) into an\n"
    "                        MCAP file that Foxglove opens; it appears when the viewer stops\n"
    "  --timeout S           exit after S seconds (default 0: until SIGINT/SIGTERM)\n"
    "  --log-level L         debug|info|warn|error\n";

struct ViewerCli {
  std::string transport_url, keys_file;
  viewer::ViewerOptions viewer;
  double timeout_s = 0.0;
};

const ConfigTable<ViewerCli>& viewerCliTable() {
  using O = ViewerCli;
  static const ConfigTable<O> table = ConfigTable<O>()
                                          .add("transport", &O::transport_url, "")
                                          .add("keys-file", &O::keys_file, "")
                                          .add("timeout", &O::timeout_s, ConfigRange::closed(0.0, 1e7), "");
  return table;
}

ViewerCli parseOptions(cli::Args& args, std::vector<std::string>* errors) {
  ViewerCli o;
  o.transport_url = args.getOr("transport", "");
  if (o.transport_url.empty()) errors->push_back("--transport URL is required");
  else if (const Status s = transport::checkTransportUrl(o.transport_url); !s)
    errors->push_back(s.error());
  o.viewer.robots = splitList(args.getOr("robots", ""));
  if (o.viewer.robots.empty()) errors->push_back("--robots a,b is required");
  o.keys_file = args.getOr("keys-file", "");
  o.viewer.open = args.has("open");
  if (o.keys_file.empty() && !o.viewer.open) errors->push_back("--keys-file FILE or --open is required");
  o.viewer.bind = args.getOr("bind", "127.0.0.1");
  o.viewer.port = static_cast<int>(args.getInt("port").value_or(8765));
  if (o.viewer.port < 0 || o.viewer.port > 65535) errors->push_back("--port must be 0..65535");
  o.viewer.max_clients = static_cast<int>(args.getInt("max-clients").value_or(16));
  if (o.viewer.max_clients < 1 || o.viewer.max_clients > 256)
    errors->push_back("--max-clients must be 1..256");
  o.viewer.cloud_period_s = args.getDouble("cloud-period").value_or(1.0);
  o.viewer.snapshot_period_s = args.getDouble("snapshot-period").value_or(30.0);
  if (!(o.viewer.cloud_period_s >= 0.0 && o.viewer.cloud_period_s <= 3600.0))
    errors->push_back("--cloud-period must be 0..3600");
  if (!(o.viewer.snapshot_period_s >= 0.1 && o.viewer.snapshot_period_s <= 86400.0))
    errors->push_back("--snapshot-period must be 0.1..86400");
  o.viewer.web_dir = args.getOr("web-dir", "");
  o.viewer.record_path = args.getOr("record", "");
  o.timeout_s = args.getDouble("timeout").value_or(0.0);
  for (const std::string& problem : viewerCliTable().problems(o)) errors->push_back("--" + problem);
  cli::applyLogLevel(args, errors);
  for (const auto& p : args.positional()) errors->push_back("unexpected argument '" + p + "'");
  return o;
}

void printStats(const viewer::ViewerStats& s) {
  std::fprintf(
      stderr,
      "rgbdmap-viewer: connections=%llu messages_sent=%llu bytes_sent=%llu dropped=%llu malformed=%llu "
      "unknown_ops=%llu refused_subscriptions=%llu map_updates=%llu map_errors=%llu rejected=%llu "
      "voxels=%llu recorded=%llu\n",
      static_cast<unsigned long long>(s.connections), static_cast<unsigned long long>(s.messages_sent),
      static_cast<unsigned long long>(s.bytes_sent), static_cast<unsigned long long>(s.dropped_messages),
      static_cast<unsigned long long>(s.malformed), static_cast<unsigned long long>(s.unknown_ops),
      static_cast<unsigned long long>(s.refused_subscriptions),
      static_cast<unsigned long long>(s.map_updates), static_cast<unsigned long long>(s.map_errors),
      static_cast<unsigned long long>(s.rejected_stream_messages), static_cast<unsigned long long>(s.voxels),
      static_cast<unsigned long long>(s.recorded_messages));
}

int runViewer(int argc, char** argv) {
  cli::Args args(argc, argv, {"help", "open"});
  if (args.has("help")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGINT, SIGTERM}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // before any thread starts; taken by waitForSignal
  signal(SIGPIPE, SIG_IGN);                       // a client that vanished mid-write is a failed write
  args.checkAllowed({"transport", "robots", "keys-file", "open", "port", "bind", "max-clients",
                     "cloud-period", "snapshot-period", "web-dir", "record", "timeout", "log-level"});
  std::vector<std::string> errors(args.errors().begin(), args.errors().end());
  ViewerCli options = parseOptions(args, &errors);
  if (!errors.empty()) return cli::usageError(errors, kUsage);
  msg::KeyStore keys;
  if (!options.keys_file.empty()) {
    auto read = msg::readKeysFile(options.keys_file);
    if (!read) return log::error(read.error()), 2;
    keys = std::move(*read);
  }
  auto viewer = viewer::Viewer::create(options.viewer, keys);
  if (!viewer) return log::error(viewer.error()), 2;
  auto transport = transport::makeTransport(options.transport_url);
  if (!transport) return log::error("transport ", options.transport_url, ": ", transport.error()), 1;
  if (const Status s = (*viewer)->subscribe(**transport); !s) return log::error(s.error()), 2;
  if (const Status s = (*viewer)->start(); !s) return log::error("viewer: ", s.error()), 1;
  if (const Status s = (*transport)->start(); !s) return log::error("transport start: ", s.error()), 1;
  log::info("rgbdmap-viewer: serving http://", options.viewer.bind, ":", (*viewer)->port(),
            "/ (Foxglove: ws://", options.viewer.bind, ":", (*viewer)->port(), ")");
  cli::waitForSignal(signals, options.timeout_s);
  (*transport)->stop();
  (*viewer)->stop();
  const viewer::ViewerStats stats = (*viewer)->stats();
  printStats(stats);
  return stats.recording_failed ? 1 : 0;
}

}  // namespace
}  // namespace rgbdmap

int main(int argc, char** argv) { return rgbdmap::runViewer(argc - 1, argv + 1); }
