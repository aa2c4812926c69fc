#include "rgbdmap/server/server_config.hpp"

namespace rgbdmap {

const ConfigTable<ServerAppConfig>& serverAppConfigTable() {
  using C = ServerAppConfig;
  static const ConfigTable<C> table =
      ConfigTable<C>()
          .nest("", &C::server, mapServerConfigTable())
          .add("server.transport", &C::transport_url,
               "memq:// (in-process) | udpm://239.255.76.67:7667?ttl=0 | dds://?domain=0 "
               "(dds:// reads CYCLONEDDS_URI, e.g. deploy/dds/cyclonedds-loopback.xml)")
          .add("server.keys_file", &C::keys_file,
               "\"robot_id hexkey\" lines (32-byte HMAC keys, 64 hex digits); empty needs open_mode")
          .add("server.open_mode", &C::open_mode,
               "accept unsigned messages from robots without a key (local demos only)");
  return table;
}

void readServerConfig(ConfigReader& r, ServerAppConfig* c) { serverAppConfigTable().read(r, c); }

std::vector<ConfigValue> serverConfigValues(const ServerAppConfig& config) {
  return serverAppConfigTable().values(config);
}

}  // namespace rgbdmap
