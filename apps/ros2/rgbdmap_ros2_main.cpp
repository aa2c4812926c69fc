// rgbdmap-ros2: the map streams as ROS 2 topics (bridge.hpp lists them). Subscribes to the map streams of
// the given robots (the server's keys file or --open) and publishes over Cyclone DDS in the ROS 2 domain
// --domain; ROS 2 nodes on that network (nav2, RViz2, rosbag2) see them without any rgbdmap package.
#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/cli/signal_thread.hpp"
#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/ros2_bridge/bridge.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap {
namespace {

const char* kUsage =
    "usage: rgbdmap-ros2 --transport URL --robots a,b (--keys-file FILE | --open) [options]\n"
    "Publishes the map as ROS 2 topics over Cyclone DDS (needs CYCLONEDDS_URI): /map, /tf, /tf_static,\n"
    "/octomap_binary, /map_cloud and per robot /R/pose, /R/path, /R/local_map.\n"
    "  --transport URL       the robot link: udpm://239.255.76.67:7667?ttl=0 | dds://?domain=0\n"
    "  --robots a,b,c        robots whose map streams to publish\n"
    "  --keys-file FILE      the server's keys file (\"robot_id hexkey\" lines)\n"
    "  --open                accept unsigned messages (server in open mode)\n"
    "  --domain N            the ROS 2 DDS domain (ROS_DOMAIN_ID, default 0)\n"
    "  --mounts 'R=x,y,z,roll,pitch,yaw;...'  camera mounts as each robot's robot.camera_mount (metres,\n"
    "                        degrees; default: a level camera at the base's origin)\n"
    "  --map-period S        /map, /octomap_binary, /map_cloud at most every S seconds (default 1)\n"
    "  --tf-period S         /tf every S seconds (default 0.05)\n"
    "  --timeout S           exit after S seconds (default 0: until SIGINT/SIGTERM)\n"
    "  --log-level L         debug|info|warn|error\n";

struct Ros2Cli {
  std::string transport_url, keys_file;
  ros2::BridgeOptions bridge;
  double timeout_s = 0.0;
};

/// "R=x,y,z,roll,pitch,yaw;..." -> T_base_camera per robot.
void parseMounts(const std::string& text, Ros2Cli* o, std::vector<std::string>* errors) {
  std::vector<std::string> items;
  for (size_t start = 0; start <= text.size();) {
    const size_t end = std::min(text.find(';', start), text.size());
    if (end > start) items.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  for (const std::string& item : items) {
    const size_t eq = item.find('=');
    const std::string robot = item.substr(0, eq);
    std::vector<double> v;
    if (eq != std::string::npos)
      for (const std::string& n : splitList(item.substr(eq + 1))) {
        char* end = nullptr;
        v.push_back(std::strtod(n.c_str(), &end));
        if (end == n.c_str() || *end != '\0') v.clear();
      }
    CameraMount mount;
    if (v.size() == 6) {
      mount.xyz_m = {v[0], v[1], v[2]};
      mount.rpy_deg = {v[3], v[4], v[5]};
    }
    const std::string problems = v.size() == 6 ? mount.validate() : "needs R=x,y,z,roll,pitch,yaw";
    const bool known =
        std::find(o->bridge.robots.begin(), o->bridge.robots.end(), robot) != o->bridge.robots.end();
    if (!problems.empty())
      errors->push_back("--mounts '" + item + "': " + problems);
    else if (!known)
      errors->push_back("--mounts: '" + robot + "' is not one of --robots");
    else
      o->bridge.mounts[robot] = mount.T_base_camera();
  }
}

Ros2Cli parseOptions(cli::Args& args, std::vector<std::string>* errors) {
  Ros2Cli o;
  o.transport_url = args.getOr("transport", "");
  if (o.transport_url.empty())
    errors->push_back("--transport URL is required");
  else if (const Status s = transport::checkTransportUrl(o.transport_url); !s)
    errors->push_back(s.error());
  o.bridge.robots = splitList(args.getOr("robots", ""));
  if (o.bridge.robots.empty()) errors->push_back("--robots a,b is required");
  o.keys_file = args.getOr("keys-file", "");
  o.bridge.open = args.has("open");
  if (o.keys_file.empty() && !o.bridge.open) errors->push_back("--keys-file FILE or --open is required");
  const long long domain = args.getInt("domain").value_or(0);
  if (domain < 0 || domain > 232) errors->push_back("--domain must be 0..232");
  o.bridge.domain = static_cast<int>(domain);
  // The ROS 2 side is DDS whatever the robot link is: the same configuration check as a dds:// link.
  if (const Status s = transport::checkTransportUrl("dds://?domain=" + std::to_string(o.bridge.domain)); !s)
    errors->push_back("ROS 2: " + s.error());
  parseMounts(args.getOr("mounts", ""), &o, errors);
  o.bridge.map_period_s = args.getDouble("map-period").value_or(1.0);
  if (!(o.bridge.map_period_s >= 0.0 && o.bridge.map_period_s <= 3600.0))
    errors->push_back("--map-period must be 0..3600");
  o.bridge.tf_period_s = args.getDouble("tf-period").value_or(0.05);
  if (!(o.bridge.tf_period_s >= 0.001 && o.bridge.tf_period_s <= 10.0))
    errors->push_back("--tf-period must be 0.001..10");
  o.timeout_s = args.getDouble("timeout").value_or(0.0);
  if (!(o.timeout_s >= 0.0 && o.timeout_s <= 1e7)) errors->push_back("--timeout must be 0..1e7");
  cli::applyLogLevel(args, errors);
  for (const auto& p : args.positional()) errors->push_back("unexpected argument '" + p + "'");
  return o;
}

int runRos2(int argc, char** argv) {
  cli::Args args(argc, argv, {"help", "open"});
  if (args.has("help")) {
    std::fputs(kUsage, stdout);
    return 0;
  }
  sigset_t signals;
  sigemptyset(&signals);
  for (int s : {SIGINT, SIGTERM}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);  // before any thread starts; taken by waitForSignal
  args.checkAllowed({"transport", "robots", "keys-file", "open", "domain", "mounts", "map-period",
                     "tf-period", "timeout", "log-level"});
  std::vector<std::string> errors(args.errors().begin(), args.errors().end());
  Ros2Cli options = parseOptions(args, &errors);
  if (!errors.empty()) return cli::usageError(errors, kUsage);
  msg::KeyStore keys;
  if (!options.keys_file.empty()) {
    auto read = msg::readKeysFile(options.keys_file);
    if (!read) return log::error(read.error()), 2;
    keys = std::move(*read);
  }
  auto bridge = ros2::Bridge::create(options.bridge, keys);
  if (!bridge) return log::error(bridge.error()), 2;
  auto transport = transport::makeTransport(options.transport_url);
  if (!transport) return log::error("transport ", options.transport_url, ": ", transport.error()), 1;
  if (const Status s = (*bridge)->subscribe(**transport); !s) return log::error(s.error()), 2;
  if (const Status s = (*bridge)->start(); !s) return log::error("ros2: ", s.error()), 1;
  if (const Status s = (*transport)->start(); !s) return log::error("transport start: ", s.error()), 1;
  log::info("rgbdmap-ros2: publishing ", options.bridge.robots.size(), " robot(s) in ROS 2 domain ",
            options.bridge.domain);
  cli::waitForSignal(signals, options.timeout_s);
  (*transport)->stop();
  (*bridge)->stop();
  const ros2::BridgeStats s = (*bridge)->stats();
  std::fprintf(
      stderr,
      "rgbdmap-ros2: published=%llu publish_errors=%llu map_updates=%llu map_errors=%llu "
      "rejected=%llu voxels=%llu\n",
      static_cast<unsigned long long>(s.published), static_cast<unsigned long long>(s.publish_errors),
      static_cast<unsigned long long>(s.map_updates), static_cast<unsigned long long>(s.map_errors),
      static_cast<unsigned long long>(s.rejected_stream_messages), static_cast<unsigned long long>(s.voxels));
  return s.publish_errors > 0 ? 1 : 0;
}

}  // namespace
}  // namespace rgbdmap

int main(int argc, char** argv) { return rgbdmap::runRos2(argc - 1, argv + 1); }
