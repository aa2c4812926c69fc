#pragma once
// rgbdmap_ros2_bridge: the map streams as ROS 2 topics, behind `rgbdmap-ros2` and `rgbdmap run --ros2`. It
// subscribes to the robots' map streams like the viewer (the server signs each robot's copy with that
// robot's key) and publishes them over Cyclone DDS as ROS 2 (Humble, Jazzy) puts them on the wire: topic
// rt/<name>, type <pkg>::msg::dds_::<Type>_, plain CDR (common/ros2/idl/ros2_msgs.idl). No ROS install.
//
// Topics (R: the robot id as a ROS name token, rosNameToken()):
//   /map             nav_msgs/OccupancyGrid      global 2-D map of the main map (as map_<id>.pgm)   latched
//   /octomap_binary  octomap_msgs/Octomap        the main map's octree, binary, id "OcTree"          latched
//   /map_cloud       sensor_msgs/PointCloud2     its occupied voxels: x y z float32, rgb (by height)  latched
//   /tf              tf2_msgs/TFMessage          M -> R/odom, R/odom -> R/base_link, every tf_period_s
//   /tf_static       tf2_msgs/TFMessage          R/base_link -> R/camera_optical_frame (the mounts)   latched
//   /R/pose          geometry_msgs/PoseStamped   R's base in M: its live pose, else newest keyframe   latched
//   /R/path          nav_msgs/Path               R's optimised keyframes' base poses in M             latched
//   /R/local_map     nav_msgs/OccupancyGrid      R's latest occupancy slice                           latched
// Latched: reliable, transient local, keep last 1 (as map_server and octomap_server); /tf: reliable,
// volatile, keep last 100 (tf2's broadcaster).
//
// Frames (REP-105): the main map is the map of the most robots (loop edges between robots tell who shares
// a map; a tie goes to the robot listed first) and its frame is "map"; a robot in another map has its map
// frame "R/map" until a loop joins it to the main one. R/odom is the base frame at the start of R's
// odometry, z-up: map -> R/odom = T_map_odom * T_base_camera^-1.
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/se3.hpp"
#include "rgbdmap/proto/envelope.hpp"
#include "rgbdmap/proto/messages.hpp"
#include "rgbdmap/transport/transport.hpp"
#include "rgbdmap/viewer/foxglove_json.hpp"

namespace rgbdmap::ros2 {

struct BridgeOptions {
  std::vector<std::string> robots;
  bool open = false;  ///< accept unsigned server messages (server in open mode)
  int domain = 0;     ///< DDS domain: the ROS 2 machines' ROS_DOMAIN_ID
  /// T_base_camera per robot (the robot's camera.mount); a robot not here has the default mount.
  std::map<std::string, SE3> mounts;
  double map_period_s = 1.0;  ///< /map, /octomap_binary, /map_cloud: at most once per period
  double tf_period_s = 0.05;  ///< /tf every period (tf2 looks transforms up by time)
};

struct BridgeStats {
  uint64_t published = 0, publish_errors = 0;
  uint64_t map_updates = 0, map_errors = 0, rejected_stream_messages = 0;
  uint64_t voxels = 0;  ///< points of the last /map_cloud
};

/// Which robots share a map: robots named by one another's loop edges (`loops[i]` of robots[i]) are one
/// group; groups in the order of their first robot, the group of the most robots first (ties: listed first).
std::vector<std::vector<std::string>> mapGroups(const std::vector<std::string>& robots,
                                                const std::vector<std::vector<msg::MapLoopEdge>>& loops);

/// T_base_camera^-1 applied: the base frame's pose in the map from the camera's.
inline SE3 baseOf(const SE3& T_map_cam, const SE3& T_base_camera) { return T_map_cam * T_base_camera.inverse(); }

/// A robot's REP-105 transforms: map -> R/odom (R's base frame at the start of its odometry) and R/odom ->
/// R/base_link, from rgbdmap's T_map_odom (whose odometry frame is the camera at the start), the camera's
/// pose in the map and the mount T_base_camera.
struct OdomTransforms {
  SE3 T_map_odom, T_odom_base;
};
OdomTransforms odomTransforms(const SE3& T_map_odom, const SE3& T_map_cam, const SE3& T_base_camera);

/// sensor_msgs/PointCloud2 data of voxel centres: x y z (float32) and rgb (float32 holding 0x00RRGGBB, as
/// PCL packs it; coloured by height like the viewer's cloud), 16 bytes a point, little-endian.
std::vector<uint8_t> pointCloudData(const std::vector<viewer::Voxel>& voxels);

class Bridge {
 public:
  /// `server_keys`: robot id -> key (the server's keys file); every robot needs one unless options.open.
  static Result<std::unique_ptr<Bridge>> create(BridgeOptions options, const msg::KeyStore& server_keys);
  ~Bridge();  ///< stop()
  Bridge(const Bridge&) = delete;
  Bridge& operator=(const Bridge&) = delete;

  /// Subscribes the robots' map streams (before or after the transport started).
  Status subscribe(transport::Transport& transport);
  /// Creates the DDS participant and writers (needs CYCLONEDDS_URI) and starts publishing.
  Status start();
  /// Stops publishing and deletes the DDS participant; the subscription handlers do nothing afterwards.
  void stop();
  BridgeStats stats() const;

  struct Impl;

 private:
  explicit Bridge(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rgbdmap::ros2
