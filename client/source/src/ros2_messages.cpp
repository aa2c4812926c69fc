// sensor_msgs/msg/Image and sensor_msgs/msg/CameraInfo in CDR: a 4-byte encapsulation header (0x00 0x01:
// little-endian, 0x00 0x00: big-endian; then options, whose last byte may count padding at the end), then
// the fields, each aligned to its own size from the end of that header; strings carry their length with
// the terminating NUL, sequences their element count.
#include "rgbdmap/source/ros2_messages.hpp"

#include <algorithm>
#include <cstring>

namespace rgbdmap::ros2 {
namespace {

/// Reads CDR fields; any read past the end (or a malformed string) sets failed() and yields zeros.
class CdrReader {
 public:
  CdrReader(const uint8_t* bytes, size_t size) : bytes_(bytes), size_(size) {
    if (size < 4 || bytes[0] != 0x00 || (bytes[1] != 0x00 && bytes[1] != 0x01)) {
      failed_ = true;
      return;
    }
    swap_ = bytes[1] == 0x00;  // big-endian encapsulation on a little-endian host
    pos_ = 4;
  }
  template <typename T>
  T pod() {
    T v{};
    align(sizeof(T));
    if (!take(sizeof(T))) return v;
    uint8_t raw[sizeof(T)];
    std::memcpy(raw, bytes_ + pos_ - sizeof(T), sizeof(T));
    if (swap_) std::reverse(raw, raw + sizeof(T));
    std::memcpy(&v, raw, sizeof(T));
    return v;
  }
  std::string string() {
    const uint32_t n = pod<uint32_t>();
    if (!take(n)) return {};
    if (n == 0 || bytes_[pos_ - 1] != 0) return failed_ = true, std::string();  // n counts the NUL
    return std::string(reinterpret_cast<const char*>(bytes_ + pos_ - n), n - 1);
  }
  ros1::Header header() {
    ros1::Header h;
    const int32_t sec = pod<int32_t>();
    h.stamp_nsec = pod<uint32_t>();
    if (sec < 0 || h.stamp_nsec >= 1000000000u) failed_ = true;
    h.stamp_sec = static_cast<uint32_t>(std::max(sec, 0));
    h.frame_id = string();
    return h;
  }
  void align(size_t n) {
    const size_t off = (pos_ - 4) % n;
    if (off != 0) take(n - off);
  }
  bool take(size_t n) {
    if (failed_ || n > size_ - pos_) return !(failed_ = true);
    pos_ += n;
    return true;
  }
  const uint8_t* at() const { return bytes_ + pos_; }
  bool failed() const { return failed_; }

 private:
  const uint8_t* bytes_;
  size_t size_, pos_ = 0;
  bool failed_ = false, swap_ = false;
};

class CdrWriter {
 public:
  CdrWriter() : out_{0x00, 0x01, 0x00, 0x00} {}
  template <typename T>
  void pod(T v) {
    while ((out_.size() - 4) % sizeof(T) != 0) out_.push_back(0);
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    out_.insert(out_.end(), p, p + sizeof(T));
  }
  void string(const std::string& s) {
    pod(static_cast<uint32_t>(s.size() + 1));
    out_.insert(out_.end(), s.begin(), s.end());
    out_.push_back(0);
  }
  /// The message's bytes: padded to a multiple of 4 with the padding counted in the encapsulation
  /// options, as Cyclone DDS (and so rmw_cyclonedds) writes them.
  std::vector<uint8_t> finish() {
    const size_t pad = (4 - (out_.size() - 4) % 4) % 4;
    out_.insert(out_.end(), pad, 0);
    out_[3] = static_cast<uint8_t>(pad);
    return std::move(out_);
  }
  void header(const ros1::Header& h) {
    pod(static_cast<int32_t>(h.stamp_sec));
    pod(h.stamp_nsec);
    string(h.frame_id);
  }
  std::vector<uint8_t> out_;
};

}  // namespace

Result<ros1::Image> decodeImage(const uint8_t* bytes, size_t size) {
  using R = Result<ros1::Image>;
  CdrReader r(bytes, size);
  if (r.failed()) return R::failure("sensor_msgs/msg/Image: not plain CDR (encapsulation header)");
  ros1::Image m;
  m.header = r.header();
  m.height = r.pod<uint32_t>();
  m.width = r.pod<uint32_t>();
  m.encoding = r.string();
  m.is_bigendian = r.pod<uint8_t>();
  m.step = r.pod<uint32_t>();
  const uint32_t n = r.pod<uint32_t>();
  const uint8_t* data = r.at();
  if (!r.take(n) || r.failed())
    return R::failure("sensor_msgs/msg/Image: message shorter than its fields say");
  if (static_cast<uint64_t>(m.step) * m.height > n)
    return R::failure("sensor_msgs/msg/Image: " + std::to_string(n) + " data bytes for " +
                      std::to_string(m.height) + " rows of " + std::to_string(m.step));
  m.data.assign(data, data + n);
  return m;
}

Result<ros1::CameraInfo> decodeCameraInfo(const uint8_t* bytes, size_t size) {
  using R = Result<ros1::CameraInfo>;
  CdrReader r(bytes, size);
  if (r.failed()) return R::failure("sensor_msgs/msg/CameraInfo: not plain CDR (encapsulation header)");
  ros1::CameraInfo c;
  c.header = r.header();
  c.height = r.pod<uint32_t>();
  c.width = r.pod<uint32_t>();
  c.distortion_model = r.string();
  const uint32_t nd = r.pod<uint32_t>();
  if (nd > 64) return R::failure("sensor_msgs/msg/CameraInfo: " + std::to_string(nd) + " distortion values");
  for (uint32_t i = 0; i < nd; ++i) c.D.push_back(r.pod<double>());
  for (double& k : c.K) k = r.pod<double>();
  for (double& v : c.R) v = r.pod<double>();
  for (double& p : c.P) p = r.pod<double>();
  if (r.failed()) return R::failure("sensor_msgs/msg/CameraInfo: message shorter than its fields");
  return c;  // binning and roi follow; not needed
}

std::vector<uint8_t> encodeImage(const ros1::Image& m) {
  CdrWriter w;
  w.header(m.header);
  w.pod(m.height);
  w.pod(m.width);
  w.string(m.encoding);
  w.pod(m.is_bigendian);
  w.pod(m.step);
  w.pod(static_cast<uint32_t>(m.data.size()));
  w.out_.insert(w.out_.end(), m.data.begin(), m.data.end());
  return w.finish();
}

std::vector<uint8_t> encodeCameraInfo(const ros1::CameraInfo& c) {
  CdrWriter w;
  w.header(c.header);
  w.pod(c.height);
  w.pod(c.width);
  w.string(c.distortion_model);
  w.pod(static_cast<uint32_t>(c.D.size()));
  for (double d : c.D) w.pod(d);
  for (double k : c.K) w.pod(k);
  for (double v : c.R) w.pod(v);
  for (double p : c.P) w.pod(p);
  for (int i = 0; i < 6; ++i) w.pod(uint32_t{0});  // binning_x, binning_y, roi x, y, height, width
  w.pod(uint8_t{0});                               // roi.do_rectify
  return w.finish();
}

}  // namespace rgbdmap::ros2
