#pragma once
// The idlc-generated ROS 2 types (dds/ros2_sensor_msgs.idl) and their conversion to and from the message
// structs of ros_messages.hpp.
#include <dds/dds.h>

#include "rgbdmap/source/ros_messages.hpp"
#include "ros2_sensor_msgs.h"

namespace rgbdmap::ros2::detail {

/// The sample as a message (copies the data); the reason when its sizes do not fit (untrusted peer).
Result<ros1::Image> fromDds(const sensor_msgs_msg_dds__Image_& sample);
Result<ros1::CameraInfo> fromDds(const sensor_msgs_msg_dds__CameraInfo_& sample);

std::string ddsError(const char* what, dds_return_t rc);
/// "rt/" + the ROS name without its leading slash (rmw's convention).
std::string ddsTopicName(const std::string& ros_name);

}  // namespace rgbdmap::ros2::detail
