#pragma once
// ROS 2 topics over Cyclone DDS without a ROS install: sensor_msgs/msg/Image and CameraInfo as
// rmw_cyclonedds puts them on the wire (topic "rt/<name>", type "sensor_msgs::msg::dds_::Image_", plain
// CDR). The reading side is the ros2: frame source (source_url.cpp); this publisher feeds it in the tests
// and tools. Uses CYCLONEDDS_URI (deploy/dds/cyclonedds-loopback.xml) like every DDS part of rgbdmap.
#include <memory>
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/source/ros_messages.hpp"

namespace rgbdmap::ros2 {

/// realsense2_camera's topics (ROS 2, align_depth.enable:=true), the ros2: source's defaults.
struct CameraTopics {
  std::string rgb = "/camera/camera/color/image_raw";
  std::string depth = "/camera/camera/aligned_depth_to_color/image_raw";
  std::string info = "/camera/camera/color/camera_info";
};

class ImagePublisher {
 public:
  /// Writers on the three topics in DDS domain `domain`, with the QoS realsense2_camera uses (reliable,
  /// volatile, keep last 10).
  static Result<std::unique_ptr<ImagePublisher>> create(int domain, const CameraTopics& topics);
  ~ImagePublisher();
  ImagePublisher(const ImagePublisher&) = delete;
  ImagePublisher& operator=(const ImagePublisher&) = delete;
  Status publishColor(const ros1::Image& image);
  Status publishDepth(const ros1::Image& image);
  Status publishInfo(const ros1::CameraInfo& info);
  /// Readers matched on each of the three topics (the subscriber has discovered this publisher).
  int matchedReaders() const;

 private:
  struct Impl;
  explicit ImagePublisher(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rgbdmap::ros2
