// ros2_wire_check: what the ros2: source's DDS types put on the wire is ROS 2's CDR. Publishes one Image and
// one CameraInfo through the idlc-generated types (as ros2_test_publisher and a ROS 2 camera driver do),
// takes them back serialised (dds_takecdr) and compares the bytes with ros2::encodeImage/encodeCameraInfo,
// the CDR whose decoding tests/cli/test_mcap_sources.sh checks against the reference serialiser
// (@foxglove/rosmsg2-serialization). Run inside the loopback-only namespace (CYCLONEDDS_URI set).
// Exit 0 when both match byte for byte.
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>

#include <chrono>
#include <cstdio>
#include <thread>
#include <vector>

#include "rgbdmap/source/ros2_messages.hpp"
#include "rgbdmap/source/ros2_topics.hpp"
#include "ros2_msgs.h"

namespace {

/// The serialised bytes of the next sample on `reader` (empty after 10 s without one).
std::vector<uint8_t> takeSerialised(dds_entity_t reader) {
  for (int i = 0; i < 500; ++i) {
    struct ddsi_serdata* data = nullptr;
    dds_sample_info_t info;
    if (dds_takecdr(reader, &data, 1, &info, DDS_ANY_STATE) == 1) {
      std::vector<uint8_t> bytes(ddsi_serdata_size(data));
      ddsi_serdata_to_ser(data, 0, bytes.size(), bytes.data());
      ddsi_serdata_unref(data);
      return bytes;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return {};
}

int compare(const char* what, const std::vector<uint8_t>& wire, const std::vector<uint8_t>& ours) {
  if (wire == ours)
    return std::printf("ok: %s: %zu bytes on the wire, byte for byte ros2::encode\n", what, wire.size()), 0;
  size_t at = 0;
  while (at < wire.size() && at < ours.size() && wire[at] == ours[at]) ++at;
  std::printf("FAIL: %s: wire %zu bytes, ours %zu, first difference at byte %zu\n", what, wire.size(),
              ours.size(), at);
  return 1;
}

}  // namespace

int main() {
  using namespace rgbdmap;
  auto publisher = ros2::ImagePublisher::create(0, {});
  if (!publisher) return std::printf("FAIL: %s\n", publisher.error().c_str()), 1;
  const dds_entity_t participant = dds_create_participant(0, nullptr, nullptr);
  const ros2::CameraTopics topics;
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  const dds_entity_t rgb =
      dds_create_reader(participant,
                        dds_create_topic(participant, &sensor_msgs_msg_dds__Image__desc,
                                         "rt/camera/camera/color/image_raw", nullptr, nullptr),
                        qos, nullptr);
  const dds_entity_t info =
      dds_create_reader(participant,
                        dds_create_topic(participant, &sensor_msgs_msg_dds__CameraInfo__desc,
                                         "rt/camera/camera/color/camera_info", nullptr, nullptr),
                        qos, nullptr);
  dds_delete_qos(qos);
  if (rgb < 0 || info < 0) return std::printf("FAIL: readers\n"), 1;
  for (int i = 0; i < 500 && (*publisher)->matchedReaders() < 1; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  cv::Mat bgr(5, 7, CV_8UC3);
  cv::randu(bgr, 0, 255);
  ros1::Image image = ros1::imageFromMat(bgr, "bgr8", 1700000000.123456);
  image.header.frame_id = "camera_color_optical_frame";
  ros1::CameraInfo c;
  c.header = image.header;
  c.width = 640, c.height = 480, c.distortion_model = "plumb_bob";
  c.D = {0.1, -0.2, 0.001, 0.002, 0.3};
  c.K = {517.3, 0, 318.6, 0, 516.5, 255.3, 0, 0, 1};
  c.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  c.P = {517.3, 0, 318.6, 0, 0, 516.5, 255.3, 0, 0, 0, 1, 0};
  if (!(*publisher)->publishColor(image) || !(*publisher)->publishInfo(c))
    return std::printf("FAIL: publish\n"), 1;
  int failed = compare("sensor_msgs/msg/Image", takeSerialised(rgb), ros2::encodeImage(image));
  failed += compare("sensor_msgs/msg/CameraInfo", takeSerialised(info), ros2::encodeCameraInfo(c));
  dds_delete(participant);
  return failed ? 1 : 0;
}
