// robot.*, transport.*, link.* keys of the robot program's configuration.
#include "rgbdmap/link/robot_client_config.hpp"

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "rgbdmap/common/common_config_tables.hpp"
#include "rgbdmap/link/link_config_tables.hpp"
#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap {

const ConfigTable<RobotClientConfig>& robotClientConfigTable() {
  using C = RobotClientConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .add("robot.id", &C::robot_id, "[A-Za-z0-9_-]{1,32}, not \"server\"; --robot-id overrides")
          .add("robot.key_file", &C::key_file,
               "file with the robot's HMAC key in hex (64 digits = 32 bytes; '#' comment lines and "
               "whitespace ignored), relative to this file's folder. The server holds the same key. "
               "Empty: unsigned messages, accepted only by a server in open mode (local demos).")
          .section("robot.camera_mount",
                   "the camera's pose on the robot (T_base_camera, sent in Hello). The map frame is the base "
                   "frame (REP-103: x forward, y left, z up) of the first robot's first keyframe, so maps, "
                   "slices and exports are z-up")
          .nest("robot.camera_mount.", &C::camera_mount, cameraMountConfigTable())
          .addChoice("robot.map_mode", &C::localize, {{false, "map"}, {true, "localize"}},
                     "map: the robot's keyframes are stored and build the map; localize: the server places "
                     "and tracks the robot in its stored map and never stores its keyframes (the map does "
                     "not change); --map-mode overrides")
          .add("robot.spool_dir", &C::spool_dir,
               "keyframe spool: every keyframe is kept in <spool_dir>/<robot id> until the server "
               "acknowledges it, and a new start sends what an earlier one left. Relative to this file's "
               "folder; empty: <--out>/spool. --spool overrides")
          .add("robot.spool_max_mb", &C::spool_max_mb, ConfigRange::closed(0, 1 << 20),
               "the spool's disk budget; a keyframe beyond it (or on a full disk) is sent live only; 0: no "
               "spool")
          .add("transport.url", &C::transport_url,
               "memq:// (in-process) | udpm://239.255.76.67:7667?ttl=0 (LCM, see deploy/lcm.md) | "
               "dds://?domain=0 (Cyclone DDS; needs CYCLONEDDS_URI, e.g. "
               "file://$PWD/deploy/dds/cyclonedds-loopback.xml). --transport overrides.")
          .nest("link.", &C::link, robotLinkConfigTable())
          .add("link.final_wait_s", &C::final_wait_s, ConfigRange::closed(0.0, 3600.0),
               "at the end: wait for every ack and a correction covering the last keyframe");
  return table;
}

void readRobotClientConfig(ConfigReader& reader, RobotClientConfig* config) {
  robotClientConfigTable().read(reader, config);
  const transport::ReliableSenderOptions& r = config->link.reliable;
  if (r.max_backoff < r.initial_backoff)
    reader.addError(reader.source() + ": link.reliable.max_backoff_ms must be >= initial_backoff_ms");
  if (r.min_backoff > r.initial_backoff)
    reader.addError(reader.source() + ": link.reliable.min_backoff_ms must be <= initial_backoff_ms");
  if (const std::string e = config->camera_mount.validate(); !e.empty())
    reader.addError(reader.source() + ": robot.camera_mount: " + e);
  config->link.T_base_camera = config->camera_mount.T_base_camera();
  config->link.localize = config->localize;
}

std::vector<ConfigValue> robotClientConfigValues(const RobotClientConfig& config) {
  return robotClientConfigTable().values(config);
}

Result<msg::Bytes> readKeyFile(const std::string& path, const std::string& base_dir) {
  std::filesystem::path p(path);
  if (p.is_relative() && !base_dir.empty()) p = std::filesystem::path(base_dir) / p;
  std::ifstream in(p);
  if (!in) {
    std::error_code ec;
    const std::string resolved = std::filesystem::absolute(p, ec).lexically_normal().string();
    return Result<msg::Bytes>::failure("cannot read key file " + p.string() +
                                       (ec || resolved == p.string() ? "" : " (" + resolved + ")") + ": " +
                                       std::strerror(errno) + " (`rgbdmap keys new ROBOT` writes one)");
  }
  std::string hex, line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t") != std::string::npos && line[line.find_first_not_of(" \t")] == '#')
      continue;
    for (const char ch : line)
      if (!std::isspace(static_cast<unsigned char>(ch))) hex += ch;
  }
  Result<msg::Bytes> key = msg::parseHexKey(hex);
  if (!key) return Result<msg::Bytes>::failure("key file " + p.string() + ": " + key.error());
  return key;
}

}  // namespace rgbdmap
