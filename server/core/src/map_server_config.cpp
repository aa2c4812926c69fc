#include "rgbdmap/server/map_server_config.hpp"

#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap {

std::string MapServerConfig::validate() const {
  std::vector<std::string> problems;
  if (map_dir.empty()) problems.push_back("map_dir is empty");
  for (const std::string& r : robots)
    if (!msg::channelFor(msg::MessageType::kHello, r)) problems.push_back("invalid robot id '" + r + "'");
  if (!(status_period_s >= 0.0 && status_period_s <= 3600.0))
    problems.push_back("status_period_s not in [0, 3600]");
  if (ingest_queue_capacity < 1 || ingest_queue_capacity > 100000)
    problems.push_back("ingest_queue_capacity not in [1, 100000]");
  if (!(default_odometry_sigma_m > 0.0 && default_odometry_sigma_m < 10.0))
    problems.push_back("default_odometry_sigma_m not in (0, 10)");
  if (!(default_odometry_sigma_deg > 0.0 && default_odometry_sigma_deg < 90.0))
    problems.push_back("default_odometry_sigma_deg not in (0, 90)");
  if (const std::string l = loop.validate(); !l.empty()) problems.push_back(l);
  if (occupancy_enabled) {
    if (const std::string o = occupancy.validate(); !o.empty()) problems.push_back("occupancy: " + o);
    if (const std::string sl = slice.validate(); !sl.empty()) problems.push_back("slice: " + sl);
  }
  if (!(slice_period_s >= 0.0 && slice_period_s <= 3600.0))
    problems.push_back("slice_period_s not in [0, 3600]");
  if (!(map_stream_period_s >= 0.0 && map_stream_period_s <= 3600.0))
    problems.push_back("map_stream_period_s not in [0, 3600]");
  std::string out;
  for (const std::string& p : problems) out += (out.empty() ? "" : "; ") + p;
  return out;
}

}  // namespace rgbdmap
