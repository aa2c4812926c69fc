#pragma once
// The two ROS 2 messages an RGB-D recording or camera driver publishes, in CDR (the encapsulation rosbag2
// and every ROS 2 DDS middleware use): sensor_msgs/msg/Image and sensor_msgs/msg/CameraInfo. Their fields
// are those of the ROS 1 messages (ros_messages.hpp, whose structs and OpenCV conversions they share);
// only the header (no seq, int32 seconds) and the wire format differ. Decoding checks every length and the
// encapsulation (little- or big-endian plain CDR) against the bytes there are: the input is untrusted.
#include <cstdint>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/source/ros_messages.hpp"

namespace rgbdmap::ros2 {

inline constexpr const char* kImageType = "sensor_msgs/msg/Image";
inline constexpr const char* kCameraInfoType = "sensor_msgs/msg/CameraInfo";

Result<ros1::Image> decodeImage(const uint8_t* bytes, size_t size);
Result<ros1::CameraInfo> decodeCameraInfo(const uint8_t* bytes, size_t size);
/// Little-endian CDR (as a ROS 2 publisher on x86 or ARM writes it); header.seq is not part of ROS 2.
std::vector<uint8_t> encodeImage(const ros1::Image& image);
std::vector<uint8_t> encodeCameraInfo(const ros1::CameraInfo& info);

}  // namespace rgbdmap::ros2
