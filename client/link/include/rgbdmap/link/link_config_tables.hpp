#pragma once
// Config tables (rgbdmap/common/config_table.hpp) of the robot link: keys (the client's `link:` section),
// ranges and meanings. The reliable-sender and codec tables live here, not next to their structs, because
// their limits are the link's (the envelope size bounds the keyframe budget).
#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/link/robot_link.hpp"

namespace rgbdmap {

const ConfigTable<transport::ReliableSenderOptions>& reliableSenderConfigTable();
const ConfigTable<ImageCodecOptions>& imageCodecConfigTable();
/// heartbeat_period_s, hello_period_s, send_timeout_s, reliable.*, codec.*; RobotLinkOptions::validate()
/// checks against it (robot id, key and camera are checked there too).
const ConfigTable<RobotLinkOptions>& robotLinkConfigTable();

}  // namespace rgbdmap
