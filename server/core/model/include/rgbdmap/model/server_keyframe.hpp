#pragma once
// A keyframe and a loop edge as the server's graph holds them now: what MapServer::keyframes() and loops()
// return, what the ingest side indexes and the map worker writes out.
#include <cstdint>
#include <string>

#include "rgbdmap/common/se3.hpp"

namespace rgbdmap {

/// One optimised keyframe as the server holds it.
struct ServerKeyframe {
  int64_t node_id = 0;
  std::string robot_id;
  int64_t session = 0;
  int segment = 0;
  int keyframe_id = 0;
  double timestamp = 0.0;
  int map_id = 0;
  SE3 T_map_kf = SE3::Identity();
  SE3 T_odom_kf = SE3::Identity();
};

/// One loop edge (within a robot or between robots) as the server's pose graph holds it now.
struct ServerLoop {
  int64_t from_node = 0, to_node = 0;  ///< ServerKeyframe::node_id
  SE3 T_from_to = SE3::Identity();
  bool inter_robot = false;
  /// False while the consistency check of the last finished whole-graph solve holds it out (a false match,
  /// or a true one the estimate did not fit then).
  bool enabled = true;
};

}  // namespace rgbdmap
