// writeTumFolderAsBag: rosbag::Bag::write with a message type that carries its serialised bytes and its ROS
// type, md5 and definition (the real sensor_msgs ones), so no generated message headers are needed.
#include "bag_test_writer.hpp"

#include <rosbag/bag.h>

#include <cstring>

#include <opencv2/imgproc.hpp>

#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/source/ros_messages.hpp"
#include "source/ros_test_messages.hpp"

namespace rgbdmap::testing {

struct SerializedRosMessage {
  const char* datatype;
  const char* md5;
  const char* definition;
  std::vector<uint8_t> bytes;
};

}  // namespace rgbdmap::testing

namespace ros::message_traits {
using rgbdmap::testing::SerializedRosMessage;
template <>
struct MD5Sum<SerializedRosMessage> {
  static const char* value(const SerializedRosMessage& m) { return m.md5; }
};
template <>
struct DataType<SerializedRosMessage> {
  static const char* value(const SerializedRosMessage& m) { return m.datatype; }
};
template <>
struct Definition<SerializedRosMessage> {
  static const char* value(const SerializedRosMessage& m) { return m.definition; }
};
}  // namespace ros::message_traits

namespace ros::serialization {
template <>
struct Serializer<rgbdmap::testing::SerializedRosMessage> {
  template <typename Stream>
  static void write(Stream& stream, const rgbdmap::testing::SerializedRosMessage& m) {
    std::memcpy(stream.advance(static_cast<uint32_t>(m.bytes.size())), m.bytes.data(), m.bytes.size());
  }
  static uint32_t serializedLength(const rgbdmap::testing::SerializedRosMessage& m) {
    return static_cast<uint32_t>(m.bytes.size());
  }
};
}  // namespace ros::serialization

namespace rgbdmap::testing {
namespace {

const char* kHeaderDefinition =
    "================================================================================\n"
    "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n";
const std::string kImageDefinition =
    std::string(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
        "uint8 is_bigendian\nuint32 step\nuint8[] data\n\n") +
    kHeaderDefinition;
const std::string kInfoDefinition =
    std::string(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] D\n"
        "float64[9] K\nfloat64[9] R\nfloat64[12] P\nuint32 binning_x\nuint32 binning_y\n"
        "sensor_msgs/RegionOfInterest roi\n\n") +
    kHeaderDefinition +
    "\n================================================================================\n"
    "MSG: sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\n"
    "bool do_rectify\n";

ros::Time rosTime(double t) {
  const ros1::Header h = ros1::imageFromMat(cv::Mat(1, 1, CV_8UC1), "mono8", t).header;
  return ros::Time(h.stamp_sec, h.stamp_nsec);
}

}  // namespace

Status writeTumFolderAsBag(const std::string& dir, const std::string& bag_path,
                           const CameraIntrinsics& camera, const BagWriteOptions& options) {
  auto dataset = openTestDataset(dir, camera);
  if (!dataset) return Status::failure(dataset.error());
  const std::string depth_type = options.depth_encoding == "16UC1" || options.depth_encoding == "32FC1"
                                     ? options.depth_encoding
                                     : "32FC1";  // another name: 32FC1 data labelled with it
  try {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    if (options.compression == "bz2")
      bag.setCompression(rosbag::compression::BZ2);
    else if (options.compression == "lz4")
      bag.setCompression(rosbag::compression::LZ4);
    else if (options.compression != "none")
      return Status::failure("unknown compression '" + options.compression + "'");
    const size_t n = options.max_frames ? std::min(options.max_frames, dataset->size()) : dataset->size();
    for (size_t i = 0; i < n; ++i) {
      auto frame = dataset->load(i);
      if (!frame) return Status::failure(frame.error());
      const FrameEntry& e = dataset->entry(i);
      cv::Mat color_image = frame->color;
      if (options.color_encoding == "mono8") cv::cvtColor(frame->color, color_image, cv::COLOR_BGR2GRAY);
      const SerializedRosMessage color{
          ros1::kImageType, ros1::kImageMd5, kImageDefinition.c_str(),
          ros1::encodeImage(ros1::imageFromMat(color_image, options.color_encoding, e.rgb_timestamp))};
      bag.write(options.rgb_topic, rosTime(e.rgb_timestamp), color);
      if (options.write_info)
        bag.write(options.info_topic, rosTime(e.rgb_timestamp),
                  SerializedRosMessage{ros1::kCameraInfoType, ros1::kCameraInfoMd5, kInfoDefinition.c_str(),
                                       ros1::encodeCameraInfo(cameraInfoFor(camera, e.rgb_timestamp))});
      if (!options.write_depth) continue;
      ros1::Image depth = ros1::imageFromMat(depthAsEncoding(frame->depth, camera.depth_scale, depth_type),
                                             depth_type, e.depth_timestamp);
      depth.encoding = options.depth_encoding;
      bag.write(options.depth_topic, rosTime(e.depth_timestamp),
                SerializedRosMessage{ros1::kImageType, ros1::kImageMd5, kImageDefinition.c_str(),
                                     ros1::encodeImage(depth)});
    }
    bag.close();
  } catch (const std::exception& e) {
    return Status::failure(bag_path + ": " + e.what());
  }
  return Status::success();
}

}  // namespace rgbdmap::testing
