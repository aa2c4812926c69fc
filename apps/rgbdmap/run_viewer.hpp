#pragma once
// rgbdmap run --viewer [PORT] and --ros2: the live map viewer (apps/viewer) and the ROS 2 topics
// (apps/ros2) inside the all-in-one job. They subscribe to the map streams on the server's memq:// bus, or on
// a transport instance of their own for lcm/dds (as a separate rgbdmap-viewer or rgbdmap-ros2 would),
// publish during the run and stay open after it, with the final map, until Ctrl-C.
#include <memory>
#include <string>
#include <vector>

#include "local_deployment.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/ros2_bridge/bridge.hpp"
#include "rgbdmap/viewer/viewer.hpp"
#include "run_plan.hpp"

namespace rgbdmap::cmd {

/// argv with a bare `--viewer` (last, or followed by another option) given its default port, so that
/// cli::Args reads `--viewer [PORT]` as an option with a value.
class ViewerArgv {
 public:
  ViewerArgv(int argc, char** argv);
  int argc() const { return static_cast<int>(pointers_.size()); }
  char** argv() { return pointers_.data(); }

 private:
  std::vector<std::string> args_;
  std::vector<char*> pointers_;
};

/// The port of --viewer (-1 without it); a bad value is appended to *errors.
int viewerPort(cli::Args& args, std::vector<std::string>* errors);

/// The ROS 2 domain: ROS_DOMAIN_ID when set (0..232), else 0; -1 (logged) when it is not a domain.
int rosDomainFromEnvironment();

/// What a run shows outside: the viewer, the ROS 2 topics, and their own transport (none on memq://).
struct RunViewer {
  std::unique_ptr<transport::Transport> transport;
  std::unique_ptr<viewer::Viewer> viewer;
  std::unique_ptr<ros2::Bridge> ros2;
  ~RunViewer();
};

struct RunViewerOptions {
  int port = -1;            ///< the viewer's port; -1: no viewer
  std::string record_path;  ///< non-empty: the viewer's topics also go into this MCAP file
  bool ros2 = false;        ///< publish the ROS 2 topics (in ROS_DOMAIN_ID, CYCLONEDDS_URI as for dds)
};

Result<std::unique_ptr<RunViewer>> startRunViewer(const RunViewerOptions& options,
                                                  const std::string& transport_url,
                                                  const std::vector<RobotPlan>& plans,
                                                  LocalDeployment& deployment);

/// Logs where the viewer and the ROS 2 topics are and blocks until SIGINT or SIGTERM.
void keepViewerOpen(const RunViewer& run_viewer);

}  // namespace rgbdmap::cmd
