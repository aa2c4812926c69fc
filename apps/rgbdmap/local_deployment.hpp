#pragma once
// rgbdmap run, step 3: a whole deployment in one process. It owns the mapping server, the transports and
// one RobotLink per robot, and stops them in order (links, the robots' transports, the server's transport,
// the server) when stop() is called or it is destroyed. memq:// is one in-process bus shared by all
// parties; with lcm (udpm://) and dds:// every party gets its own transport instance, as separate processes
// would.
#include <memory>
#include <string>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/link/robot_link.hpp"
#include "rgbdmap/server/map_server.hpp"
#include "rgbdmap/transport/transport.hpp"

namespace rgbdmap::cmd {

/// Cyclone DDS must never run with its default configuration here (it multicasts on the real interface):
/// sets CYCLONEDDS_URI to the shipped loopback configuration (share/rgbdmap/dds, findDataFile) unless it is
/// set.
Status ensureDdsConfig();

struct LocalRobotSpec {
  std::string id;
  msg::Bytes key;           ///< the server gets every robot's key: messages are signed as in a deployment
  CameraIntrinsics camera;  ///< sent in Hello
  SE3 T_base_camera = defaultT_base_camera();  ///< sent in Hello: the camera's pose on the robot
};

class LocalDeployment {
 public:
  /// Creates the transports (for dds:// without CYCLONEDDS_URI it points Cyclone DDS at the loopback-only
  /// configuration), starts the server on `config` (its robots become `robots`' ids) and one link per robot.
  static Result<std::unique_ptr<LocalDeployment>> start(const std::string& transport_url,
                                                        MapServerConfig config,
                                                        const std::vector<LocalRobotSpec>& robots);
  ~LocalDeployment();  ///< stop()
  LocalDeployment(const LocalDeployment&) = delete;
  LocalDeployment& operator=(const LocalDeployment&) = delete;

  /// After the robots' runs: waits (up to idle_timeout_s) until the server has ingested everything and
  /// published its last optimisation, then (up to robot_timeout_s per robot) until every robot with keyframes
  /// on the server has a correction for its newest one and has applied that last optimisation's corrections.
  void settle(double idle_timeout_s, double robot_timeout_s);
  /// Stops the links, the robots' transports, the server's transport and the server; idempotent.
  void stop();

  MapServer& server() { return *server_; }
  /// The server's transport (on memq:// the bus every party shares; the viewer subscribes to it).
  transport::Transport& serverTransport() { return *server_transport_; }
  RobotLink& link(size_t robot) { return *robots_[robot].link; }
  size_t robotCount() const { return robots_.size(); }

 private:
  struct Party {
    std::unique_ptr<transport::Transport> own_transport;  ///< empty on the shared memq:// bus
    std::unique_ptr<RobotLink> link;                      ///< declared after its transport: destroyed first
  };

  LocalDeployment() = default;
  Status addRobots(const std::string& transport_url, const std::vector<LocalRobotSpec>& robots);
  Status startTransportsAndLinks();

  // Declaration order is destruction order in reverse: robots, then the server, then its transport.
  std::unique_ptr<transport::Transport> server_transport_;
  std::unique_ptr<MapServer> server_;
  std::vector<Party> robots_;
  std::vector<std::string> robot_ids_;
  bool stopped_ = false;
};

}  // namespace rgbdmap::cmd
