#pragma once
// The robot program's configuration (deploy/config/client.yaml): robot id, key file, transport URL, link,
// reliable-sender and keyframe-codec settings. Read through its config table (every key optional, ranges
// checked, all errors collected); the camera:, dataset: and odometry: sections are read by
// odometry_config_io.hpp exactly as for `rgbdmap odometry --config`.
#include <string>
#include <vector>

#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/common/config_reader.hpp"
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/link/robot_link.hpp"

namespace rgbdmap {

struct RobotClientConfig {
  std::string robot_id = "robot0";
  std::string key_file;      ///< hex key (64 digits for 32 bytes); empty = unsigned (open-mode server)
  CameraMount camera_mount;  ///< where the camera sits on the robot: link.T_base_camera (the map is z-up)
  bool localize = false;     ///< robot.map_mode: "localize" (link.localize) or "map"
  std::string transport_url = "memq://";  ///< memq:// | udpm://... | dds://?domain=N
  double final_wait_s = 20.0;             ///< at the end, wait this long for acks and the last correction
  /// The keyframe spool's parent folder (the robot's spool is <spool_dir>/<robot id>); empty: <--out>/spool.
  /// Relative to the configuration file's folder. spool_max_mb 0: no spool (keyframes in memory only).
  std::string spool_dir;
  int spool_max_mb = 2048;
  /// heartbeat/hello periods, send timeout, reliable and codec settings; robot_id, key and camera are filled
  /// in by the program.
  RobotLinkOptions link;
};

/// robot.* (incl. robot.camera_mount.*), transport.*, link.* (incl. link.reliable.*, link.codec.*).
const ConfigTable<RobotClientConfig>& robotClientConfigTable();

/// Reads robot.*, transport.*, link.* (incl. link.reliable.*, link.codec.*) into *config.
void readRobotClientConfig(ConfigReader& reader, RobotClientConfig* config);

/// The file's keys with these values, as documented and logged.
std::vector<ConfigValue> robotClientConfigValues(const RobotClientConfig& config);

/// Reads a key file: hex digits (whitespace ignored; '#' starts a comment line). Relative paths are taken
/// relative to `base_dir` (the configuration file's folder) when it is not empty.
Result<msg::Bytes> readKeyFile(const std::string& path, const std::string& base_dir = "");

}  // namespace rgbdmap
