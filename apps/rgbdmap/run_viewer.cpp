#include "run_viewer.hpp"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

#include "rgbdmap/common/logging.hpp"

namespace rgbdmap::cmd {
namespace {

constexpr int kDefaultViewerPort = 8765;
int g_signal_pipe[2] = {-1, -1};

void onSignal(int) {
  const char byte = 1;
  const ssize_t ignored = write(g_signal_pipe[1], &byte, 1);  // async-signal-safe
  (void)ignored;
}

}  // namespace

ViewerArgv::ViewerArgv(int argc, char** argv) {
  for (int i = 0; i < argc; ++i) {
    args_.emplace_back(argv[i]);
    const bool bare =
        args_.back() == "--viewer" && (i + 1 == argc || std::string(argv[i + 1]).rfind("--", 0) == 0);
    if (bare) args_.back() = "--viewer=" + std::to_string(kDefaultViewerPort);
  }
  for (std::string& a : args_) pointers_.push_back(a.data());
}

int viewerPort(cli::Args& args, std::vector<std::string>* errors) {
  if (!args.has("viewer")) return -1;
  const auto port = args.getInt("viewer");
  if (!port || *port < 0 || *port > 65535) {
    errors->push_back("--viewer PORT must be 0..65535");
    return -1;
  }
  return static_cast<int>(*port);
}

int rosDomainFromEnvironment() {
  const char* text = std::getenv("ROS_DOMAIN_ID");
  if (text == nullptr || *text == '\0') return 0;
  char* end = nullptr;
  const long domain = std::strtol(text, &end, 10);
  if (*end != '\0' || domain < 0 || domain > 232) {
    log::error("ROS_DOMAIN_ID='", text, "' is not a ROS 2 domain (0..232)");
    return -1;
  }
  return static_cast<int>(domain);
}

RunViewer::~RunViewer() {
  if (transport) transport->stop();
  if (viewer) viewer->stop();
  if (ros2) ros2->stop();
}

Result<std::unique_ptr<RunViewer>> startRunViewer(const RunViewerOptions& options,
                                                  const std::string& transport_url,
                                                  const std::vector<RobotPlan>& plans,
                                                  LocalDeployment& deployment) {
  using R = Result<std::unique_ptr<RunViewer>>;
  msg::KeyStore keys;
  std::vector<std::string> robots;
  for (const RobotPlan& p : plans) {
    robots.push_back(p.id);
    if (const Status s = keys.add(p.id, p.key); !s) return R::failure(s.error());
  }
  auto run_viewer = std::make_unique<RunViewer>();
  transport::Transport* transport = &deployment.serverTransport();
  if (transport_url.rfind("memq://", 0) != 0) {
    auto own = transport::makeTransport(transport_url);
    if (!own) return R::failure(own.error());
    run_viewer->transport = std::move(*own);
    transport = run_viewer->transport.get();
  }
  if (options.port >= 0) {
    viewer::ViewerOptions o;
    o.robots = robots;
    o.port = options.port;
    o.record_path = options.record_path;
    auto created = viewer::Viewer::create(o, keys);
    if (!created) return R::failure(created.error());
    run_viewer->viewer = std::move(*created);
    if (const Status s = run_viewer->viewer->subscribe(*transport); !s) return R::failure(s.error());
    if (const Status s = run_viewer->viewer->start(); !s) return R::failure("viewer: " + s.error());
  }
  if (options.ros2) {
    ros2::BridgeOptions o;
    o.robots = robots;
    o.domain = rosDomainFromEnvironment();
    if (o.domain < 0) return R::failure("--ros2: set ROS_DOMAIN_ID to 0..232 or unset it");
    if (const Status s = ensureDdsConfig(); !s) return R::failure("--ros2: " + s.error());
    auto created = ros2::Bridge::create(o, keys);
    if (!created) return R::failure(created.error());
    run_viewer->ros2 = std::move(*created);
    if (const Status s = run_viewer->ros2->subscribe(*transport); !s) return R::failure(s.error());
    if (const Status s = run_viewer->ros2->start(); !s) return R::failure("ros2: " + s.error());
    log::info(
        "ros2: publishing /map, /tf, /octomap_binary, /map_cloud and /<robot>/{pose,path,local_map} in "
        "ROS 2 domain ",
        o.domain);
  }
  if (run_viewer->transport)
    if (const Status s = run_viewer->transport->start(); !s)
      return R::failure("viewer transport: " + s.error());
  if (run_viewer->viewer)
    log::info("viewer: http://127.0.0.1:", run_viewer->viewer->port(),
              "/ (Foxglove: ws://127.0.0.1:", run_viewer->viewer->port(), ")");
  return R(std::move(run_viewer));
}

void keepViewerOpen(const RunViewer& run_viewer) {
  if (pipe(g_signal_pipe) != 0) return;
  struct sigaction action = {};
  action.sa_handler = onSignal;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  if (run_viewer.viewer)
    log::info("viewer: the map stays at http://127.0.0.1:", run_viewer.viewer->port(), "/ until Ctrl-C");
  if (run_viewer.ros2) log::info("ros2: the map stays on the ROS 2 topics until Ctrl-C");
  char byte = 0;
  while (read(g_signal_pipe[0], &byte, 1) < 0 && errno == EINTR) {
  }
  if (run_viewer.ros2) {
    const ros2::BridgeStats s = run_viewer.ros2->stats();
    log::info("ros2: closing (", s.published, " samples published, ", s.publish_errors, " errors, ", s.voxels,
              " voxels in /map_cloud)");
  }
  if (!run_viewer.viewer) return;
  const viewer::ViewerStats s = run_viewer.viewer->stats();
  log::info("viewer: closing (", s.connections, " connections, ", s.messages_sent, " messages, ",
            s.bytes_sent, " bytes sent, dropped ", s.dropped_messages, ", malformed ", s.malformed,
            ", unknown ops ", s.unknown_ops, ", refused subscriptions ", s.refused_subscriptions,
            ", refused connections ", s.refused_connections, ")");
}

}  // namespace rgbdmap::cmd
