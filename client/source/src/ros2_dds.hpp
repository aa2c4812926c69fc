#pragma once
// The idlc-generated ROS 2 types (common/ros2/idl/ros2_msgs.idl) and their conversion to the message
// structs of ros_messages.hpp.
#include "rgbdmap/ros2/dds.hpp"
#include "rgbdmap/source/ros_messages.hpp"

namespace rgbdmap::ros2::detail {

/// The sample as a message (copies the data); the reason when its sizes do not fit (untrusted peer).
Result<ros1::Image> fromDds(const sensor_msgs_msg_dds__Image_& sample);
Result<ros1::CameraInfo> fromDds(const sensor_msgs_msg_dds__CameraInfo_& sample);

}  // namespace rgbdmap::ros2::detail
