// Conversions between the DDS samples and the message structs, and the test/tool publisher.
#include <cstdlib>
#include <cstring>

#include "rgbdmap/source/ros2_topics.hpp"
#include "ros2_dds.hpp"

namespace rgbdmap::ros2 {
namespace detail {
namespace {

ros1::Header headerOf(const std_msgs_msg_dds__Header_& h) {
  ros1::Header out;
  out.stamp_sec = static_cast<uint32_t>(std::max<int32_t>(0, h.stamp.sec));
  out.stamp_nsec = h.stamp.nanosec;
  out.frame_id = h.frame_id ? h.frame_id : "";
  return out;
}

std_msgs_msg_dds__Header_ toDds(const ros1::Header& h) {
  std_msgs_msg_dds__Header_ out{};
  out.stamp.sec = static_cast<int32_t>(h.stamp_sec);
  out.stamp.nanosec = h.stamp_nsec;
  out.frame_id = const_cast<char*>(h.frame_id.c_str());
  return out;
}

}  // namespace

Result<ros1::Image> fromDds(const sensor_msgs_msg_dds__Image_& s) {
  ros1::Image m;
  m.header = headerOf(s.header);
  m.height = s.height;
  m.width = s.width;
  m.encoding = s.encoding ? s.encoding : "";
  m.is_bigendian = s.is_bigendian;
  m.step = s.step;
  if (static_cast<uint64_t>(m.step) * m.height > s.data._length)
    return Result<ros1::Image>::failure("sensor_msgs/msg/Image: " + std::to_string(s.data._length) +
                                        " data bytes for " + std::to_string(m.height) + " rows of " +
                                        std::to_string(m.step));
  m.data.assign(s.data._buffer, s.data._buffer + s.data._length);
  return m;
}

Result<ros1::CameraInfo> fromDds(const sensor_msgs_msg_dds__CameraInfo_& s) {
  ros1::CameraInfo c;
  c.header = headerOf(s.header);
  c.height = s.height;
  c.width = s.width;
  c.distortion_model = s.distortion_model ? s.distortion_model : "";
  if (s.d._length > 64)
    return Result<ros1::CameraInfo>::failure("sensor_msgs/msg/CameraInfo: " + std::to_string(s.d._length) +
                                             " distortion values");
  c.D.assign(s.d._buffer, s.d._buffer + s.d._length);
  std::memcpy(c.K.data(), s.k, sizeof(s.k));
  std::memcpy(c.R.data(), s.r, sizeof(s.r));
  std::memcpy(c.P.data(), s.p, sizeof(s.p));
  return c;
}

}  // namespace detail

struct ImagePublisher::Impl {
  dds_entity_t participant = 0, rgb = 0, depth = 0, info = 0;
};

ImagePublisher::ImagePublisher(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

ImagePublisher::~ImagePublisher() {
  if (impl_->participant > 0) dds_delete(impl_->participant);
}

Result<std::unique_ptr<ImagePublisher>> ImagePublisher::create(int domain, const CameraTopics& topics) {
  using R = Result<std::unique_ptr<ImagePublisher>>;
  if (Status s = checkDdsConfiguration(); !s) return R::failure(s.error());
  auto impl = std::make_unique<Impl>();
  impl->participant = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
  if (impl->participant < 0) return R::failure(ddsError("dds_create_participant", impl->participant));
  std::unique_ptr<ImagePublisher> p(new ImagePublisher(std::move(impl)));
  // realsense2_camera's QoS: reliable, volatile, keep last 10.
  auto writer = [&](const std::string& name, const dds_topic_descriptor_t* desc, dds_entity_t* out) {
    auto w = createWriter(p->impl_->participant, desc, name, defaultQos());
    if (w) *out = *w;
    return w.ok();
  };
  const bool ok = writer(topics.rgb, &sensor_msgs_msg_dds__Image__desc, &p->impl_->rgb) &&
                  writer(topics.depth, &sensor_msgs_msg_dds__Image__desc, &p->impl_->depth) &&
                  writer(topics.info, &sensor_msgs_msg_dds__CameraInfo__desc, &p->impl_->info);
  if (!ok) return R::failure("ROS 2 publisher: cannot create its DDS topics and writers");
  return R(std::move(p));
}

namespace {

Status writeImage(dds_entity_t writer, const ros1::Image& m) {
  sensor_msgs_msg_dds__Image_ s{};
  s.header = detail::toDds(m.header);
  s.height = m.height;
  s.width = m.width;
  s.encoding = const_cast<char*>(m.encoding.c_str());
  s.is_bigendian = m.is_bigendian;
  s.step = m.step;
  s.data._length = s.data._maximum = static_cast<uint32_t>(m.data.size());
  s.data._buffer = const_cast<uint8_t*>(m.data.data());
  s.data._release = false;
  const dds_return_t rc = dds_write(writer, &s);
  return rc < 0 ? Status::failure(ddsError("dds_write", rc)) : Status::success();
}

}  // namespace

Status ImagePublisher::publishColor(const ros1::Image& image) { return writeImage(impl_->rgb, image); }
Status ImagePublisher::publishDepth(const ros1::Image& image) { return writeImage(impl_->depth, image); }

Status ImagePublisher::publishInfo(const ros1::CameraInfo& c) {
  sensor_msgs_msg_dds__CameraInfo_ s{};
  s.header = detail::toDds(c.header);
  s.height = c.height;
  s.width = c.width;
  s.distortion_model = const_cast<char*>(c.distortion_model.c_str());
  s.d._length = s.d._maximum = static_cast<uint32_t>(c.D.size());
  s.d._buffer = const_cast<double*>(c.D.data());
  s.d._release = false;
  std::memcpy(s.k, c.K.data(), sizeof(s.k));
  std::memcpy(s.r, c.R.data(), sizeof(s.r));
  std::memcpy(s.p, c.P.data(), sizeof(s.p));
  const dds_return_t rc = dds_write(impl_->info, &s);
  return rc < 0 ? Status::failure(ddsError("dds_write", rc)) : Status::success();
}

int ImagePublisher::matchedReaders() const {
  int least = INT32_MAX;
  for (dds_entity_t w : {impl_->rgb, impl_->depth, impl_->info}) {
    dds_publication_matched_status_t st{};
    dds_get_publication_matched_status(w, &st);
    least = std::min<int>(least, static_cast<int>(st.current_count));
  }
  return least;
}

}  // namespace rgbdmap::ros2
