#pragma once
// What the rgbdmap-server program (and `rgbdmap run`) reads from its YAML configuration. Every key is
// documented in deploy/config/server.yaml; a test renders the table below and compares it with that file.
#include <string>
#include <vector>

#include "rgbdmap/common/config_reader.hpp"
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/server/map_server.hpp"

namespace rgbdmap {

struct ServerAppConfig {
  MapServerConfig server;
  std::string transport_url = "memq://";  ///< memq:// | udpm://239.255.76.67:7667?ttl=0 | dds://?domain=0
  std::string keys_file;                  ///< "robot_id hexkey" lines; empty: open mode must be on
  bool open_mode = false;                 ///< accept unsigned messages from robots without a key (demos)
};

/// Every key of the file: mapServerConfigTable() plus server.transport, server.keys_file, server.open_mode.
const ConfigTable<ServerAppConfig>& serverAppConfigTable();

/// Reads every key (server.*, loop.*, graph.*, map.*, slice.*); problems are recorded in the reader.
void readServerConfig(ConfigReader& reader, ServerAppConfig* config);

/// The file's keys with these values, as documented and logged.
std::vector<ConfigValue> serverConfigValues(const ServerAppConfig& config);

}  // namespace rgbdmap
