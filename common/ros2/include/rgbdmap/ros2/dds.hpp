#pragma once
// ROS 2 topics over Cyclone DDS without a ROS install, as rmw_cyclonedds_cpp puts them on the wire: topic
// "rt/<name>", the idlc types of ros2_msgs.idl (ros2_msgs.h), and the ROS 2 QoS profiles. Like every DDS
// part of rgbdmap it needs an explicit CYCLONEDDS_URI (deploy/dds/cyclonedds-*.xml).
#include <dds/dds.h>

#include <string>

#include "rgbdmap/common/result.hpp"
#include "ros2_msgs.h"

namespace rgbdmap::ros2 {

/// Cyclone's built-in default multicasts on every interface: the reason when CYCLONEDDS_URI is not set.
Status checkDdsConfiguration();

std::string ddsError(const char* what, dds_return_t rc);
/// "rt/" + the ROS name without its leading slash (rmw's convention).
std::string ddsTopicName(const std::string& ros_name);

/// A ROS 2 QoS profile as rmw_cyclonedds maps it: reliability, durability, keep-last depth.
struct Qos {
  bool reliable = true;
  bool transient_local = false;
  int depth = 10;
};
/// rclcpp's default (reliable, volatile, 10): poses, paths, tf (depth 100).
inline Qos defaultQos(int depth = 10) { return {true, false, depth}; }
/// A latched map (map_server, octomap_server, tf_static): reliable, transient local, the last one.
inline Qos latchedQos() { return {true, true, 1}; }

/// A topic of `type` and a writer of it with `qos` on `participant`; the reason on failure.
Result<dds_entity_t> createWriter(dds_entity_t participant, const dds_topic_descriptor_t* type,
                                  const std::string& ros_name, const Qos& qos);

/// A ROS name (graph name token) from an identifier: [A-Za-z0-9_] kept, every other character '_', and a
/// leading digit prefixed with '_'; "robot0" stays "robot0", "robot-1" becomes "robot_1".
std::string rosNameToken(const std::string& id);

}  // namespace rgbdmap::ros2
