#include "source/mcap_test_writer.hpp"

#include <opencv2/imgproc.hpp>

#include "rgbdmap/dataset/tum_dataset.hpp"
#include "rgbdmap/mcap/mcap_writer.hpp"
#include "rgbdmap/source/ros2_messages.hpp"
#include "source/ros_test_messages.hpp"

namespace rgbdmap::testing {
namespace {

std::vector<uint8_t> text(const std::string& s) { return {s.begin(), s.end()}; }

uint64_t nanoseconds(const ros1::Header& h) { return uint64_t{h.stamp_sec} * 1000000000u + h.stamp_nsec; }

}  // namespace

Status writeTumFolderAsMcap(const std::string& dir, const std::string& mcap_path,
                            const CameraIntrinsics& camera, const McapWriteOptions& options) {
  auto dataset = openTestDataset(dir, camera);
  if (!dataset) return Status::failure(dataset.error());
  mcap::WriterOptions wo;
  wo.compression = options.compression;
  wo.chunk_bytes = options.chunk_bytes;
  auto writer = mcap::Writer::create(mcap_path, wo);
  if (!writer) return Status::failure(writer.error());
  mcap::Writer& w = **writer;
  const uint16_t image_schema =
      w.addSchema(ros2::kImageType, "ros2msg",
                  text("std_msgs/Header header\nuint32 height\nuint32 width\n"
                       "string encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n"));
  const uint16_t info_schema =
      w.addSchema(ros2::kCameraInfoType, "ros2msg", text("# (abridged for the tests)\n"));
  const uint16_t rgb = w.addChannel(image_schema, options.rgb_topic, "cdr");
  const uint16_t depth = w.addChannel(image_schema, options.depth_topic, "cdr");
  const uint16_t info = w.addChannel(info_schema, options.info_topic, "cdr");
  const size_t n = options.max_frames ? std::min(options.max_frames, dataset->size()) : dataset->size();
  uint32_t sequence = 0;
  auto put = [&](uint16_t channel, const ros1::Header& h, std::vector<uint8_t> bytes) {
    return w.write({channel, sequence++, nanoseconds(h), nanoseconds(h), std::move(bytes)});
  };
  for (size_t i = 0; i < n; ++i) {
    auto frame = dataset->load(i);
    if (!frame) return Status::failure(frame.error());
    const FrameEntry& e = dataset->entry(i);
    cv::Mat color_image = frame->color;
    if (options.color_encoding == "mono8") cv::cvtColor(frame->color, color_image, cv::COLOR_BGR2GRAY);
    const ros1::Image color = ros1::imageFromMat(color_image, options.color_encoding, e.rgb_timestamp);
    if (Status s = put(rgb, color.header, ros2::encodeImage(color)); !s) return s;
    if (options.write_info) {
      const ros1::CameraInfo c = cameraInfoFor(camera, e.rgb_timestamp);
      if (Status s = put(info, c.header, ros2::encodeCameraInfo(c)); !s) return s;
    }
    const ros1::Image d16 =
        ros1::imageFromMat(depthAsEncoding(frame->depth, camera.depth_scale, options.depth_encoding),
                           options.depth_encoding, e.depth_timestamp);
    if (Status s = put(depth, d16.header, ros2::encodeImage(d16)); !s) return s;
  }
  return w.close();
}

}  // namespace rgbdmap::testing
