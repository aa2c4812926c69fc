// sensor_msgs/Image and sensor_msgs/CameraInfo: ROS 1 serialisation, checked decoding, OpenCV conversion.
#include "rgbdmap/source/ros_messages.hpp"

#include <cmath>
#include <cstring>

#include <opencv2/imgproc.hpp>

namespace rgbdmap::ros1 {
namespace {

/// Reads little-endian fields; any read past the end sets failed_ and yields zeros.
class Reader {
 public:
  Reader(const uint8_t* bytes, size_t size) : bytes_(bytes), size_(size) {}
  template <typename T>
  T pod() {
    T v{};
    if (!take(sizeof(T))) return v;
    std::memcpy(&v, bytes_ + pos_ - sizeof(T), sizeof(T));
    return v;
  }
  std::string string() {
    const uint32_t n = pod<uint32_t>();
    if (!take(n)) return {};
    return std::string(reinterpret_cast<const char*>(bytes_ + pos_ - n), n);
  }
  bool take(size_t n) {
    if (failed_ || n > size_ - pos_) return !(failed_ = true);
    pos_ += n;
    return true;
  }
  Header header() {
    Header h;
    h.seq = pod<uint32_t>();
    h.stamp_sec = pod<uint32_t>();
    h.stamp_nsec = pod<uint32_t>();
    h.frame_id = string();
    return h;
  }
  const uint8_t* at() const { return bytes_ + pos_; }
  bool failed() const { return failed_; }

 private:
  const uint8_t* bytes_;
  size_t size_, pos_ = 0;
  bool failed_ = false;
};

class Writer {
 public:
  template <typename T>
  void pod(T v) {
    const auto* p = reinterpret_cast<const uint8_t*>(&v);
    out_.insert(out_.end(), p, p + sizeof(T));
  }
  void bytes(const void* data, size_t n) {
    pod(static_cast<uint32_t>(n));
    const auto* p = static_cast<const uint8_t*>(data);
    out_.insert(out_.end(), p, p + n);
  }
  void header(const Header& h) {
    pod(h.seq);
    pod(h.stamp_sec);
    pod(h.stamp_nsec);
    bytes(h.frame_id.data(), h.frame_id.size());
  }
  std::vector<uint8_t> out_;
};

}  // namespace

Result<Image> decodeImage(const uint8_t* bytes, size_t size) {
  Reader r(bytes, size);
  Image m;
  m.header = r.header();
  m.height = r.pod<uint32_t>();
  m.width = r.pod<uint32_t>();
  m.encoding = r.string();
  m.is_bigendian = r.pod<uint8_t>();
  m.step = r.pod<uint32_t>();
  const uint32_t n = r.pod<uint32_t>();
  const uint8_t* data = r.at();
  if (!r.take(n)) return Result<Image>::failure("sensor_msgs/Image: message shorter than its fields say");
  m.data.assign(data, data + n);
  if (static_cast<uint64_t>(m.step) * m.height > n)
    return Result<Image>::failure("sensor_msgs/Image: " + std::to_string(n) + " data bytes for " +
                                  std::to_string(m.height) + " rows of " + std::to_string(m.step));
  return m;
}

Result<CameraInfo> decodeCameraInfo(const uint8_t* bytes, size_t size) {
  Reader r(bytes, size);
  CameraInfo c;
  c.header = r.header();
  c.height = r.pod<uint32_t>();
  c.width = r.pod<uint32_t>();
  c.distortion_model = r.string();
  const uint32_t nd = r.pod<uint32_t>();
  if (nd > 64)
    return Result<CameraInfo>::failure("sensor_msgs/CameraInfo: " + std::to_string(nd) + " D values");
  for (uint32_t i = 0; i < nd; ++i) c.D.push_back(r.pod<double>());
  for (double& k : c.K) k = r.pod<double>();
  for (double& v : c.R) v = r.pod<double>();
  for (double& p : c.P) p = r.pod<double>();
  if (r.failed())
    return Result<CameraInfo>::failure("sensor_msgs/CameraInfo: message shorter than its fields");
  return c;  // binning and roi follow; not needed
}

std::vector<uint8_t> encodeImage(const Image& m) {
  Writer w;
  w.header(m.header);
  w.pod(m.height);
  w.pod(m.width);
  w.bytes(m.encoding.data(), m.encoding.size());
  w.pod(m.is_bigendian);
  w.pod(m.step);
  w.bytes(m.data.data(), m.data.size());
  return std::move(w.out_);
}

std::vector<uint8_t> encodeCameraInfo(const CameraInfo& c) {
  Writer w;
  w.header(c.header);
  w.pod(c.height);
  w.pod(c.width);
  w.bytes(c.distortion_model.data(), c.distortion_model.size());
  w.pod(static_cast<uint32_t>(c.D.size()));
  for (double d : c.D) w.pod(d);
  for (double k : c.K) w.pod(k);
  for (double v : c.R) w.pod(v);
  for (double p : c.P) w.pod(p);
  for (int i = 0; i < 6; ++i) w.pod(uint32_t{0});  // binning_x, binning_y, roi x, y, height, width
  w.pod(uint8_t{0});                               // roi.do_rectify
  return std::move(w.out_);
}

namespace {

/// The image's rows as a matrix of `type` (a view on m.data); the reason when the sizes do not fit.
Result<cv::Mat> view(const Image& m, int type) {
  const size_t row = static_cast<size_t>(m.width) * CV_ELEM_SIZE(type);
  if (m.width == 0 || m.height == 0 || m.width > 16384 || m.height > 16384 || m.step < row)
    return Result<cv::Mat>::failure("image " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                                    " with step " + std::to_string(m.step) + " is not valid for " +
                                    m.encoding);
  return cv::Mat(static_cast<int>(m.height), static_cast<int>(m.width), type,
                 const_cast<uint8_t*>(m.data.data()), m.step);
}

bool hostIsBigEndian() {
  const uint16_t one = 1;
  return *reinterpret_cast<const uint8_t*>(&one) == 0;
}

}  // namespace

Result<cv::Mat> colorFromImage(const Image& m) {
  cv::Mat bgr;
  if (m.encoding == "rgb8" || m.encoding == "bgr8") {
    auto v = view(m, CV_8UC3);
    if (!v) return v;
    if (m.encoding == "rgb8")
      cv::cvtColor(*v, bgr, cv::COLOR_RGB2BGR);
    else
      bgr = v->clone();
  } else if (m.encoding == "mono8") {
    auto v = view(m, CV_8UC1);
    if (!v) return v;
    cv::cvtColor(*v, bgr, cv::COLOR_GRAY2BGR);
  } else {
    return Result<cv::Mat>::failure("unsupported colour encoding '" + m.encoding + "' (rgb8, bgr8, mono8)");
  }
  return bgr;
}

Result<cv::Mat> depthFromImage(const Image& m, double* depth_scale) {
  const bool swap = (m.is_bigendian != 0) != hostIsBigEndian();
  if (m.encoding == "16UC1") {
    auto v = view(m, CV_16UC1);
    if (!v) return v;
    cv::Mat depth = v->clone();
    if (swap)
      depth.forEach<uint16_t>([](uint16_t& d, const int*) { d = static_cast<uint16_t>(d << 8 | d >> 8); });
    *depth_scale = 1000.0;
    return depth;
  }
  if (m.encoding != "32FC1")
    return Result<cv::Mat>::failure("unsupported depth encoding '" + m.encoding +
                                    "' (32FC1 metres, 16UC1 millimetres)");
  auto v = view(m, CV_32FC1);
  if (!v) return v;
  constexpr double kScale = 5000.0;
  cv::Mat depth(v->size(), CV_16UC1);
  for (int y = 0; y < depth.rows; ++y) {
    const auto* src = v->ptr<uint8_t>(y);
    auto* dst = depth.ptr<uint16_t>(y);
    for (int x = 0; x < depth.cols; ++x) {
      uint8_t b[4];
      std::memcpy(b, src + 4 * x, 4);
      if (swap) std::swap(b[0], b[3]), std::swap(b[1], b[2]);
      float metres;
      std::memcpy(&metres, b, 4);
      const double raw = std::round(static_cast<double>(metres) * kScale);
      dst[x] = std::isfinite(metres) && raw > 0 && raw <= 65535 ? static_cast<uint16_t>(raw) : 0;
    }
  }
  *depth_scale = kScale;
  return depth;
}

Result<CameraIntrinsics> cameraFromInfo(const CameraInfo& info) {
  CameraIntrinsics c;
  c.fx = info.K[0];
  c.fy = info.K[4];
  c.cx = info.K[2];
  c.cy = info.K[5];
  c.width = static_cast<int>(info.width);
  c.height = static_cast<int>(info.height);
  c.distortion.fill(0.0);
  const bool plumb = info.distortion_model == "plumb_bob" || info.distortion_model == "rational_polynomial";
  if (plumb)
    for (size_t i = 0; i < std::min<size_t>(5, info.D.size()); ++i) c.distortion[i] = info.D[i];
  if (const std::string e = c.validate(); !e.empty())
    return Result<CameraIntrinsics>::failure("sensor_msgs/CameraInfo: " + e);
  return c;
}

Image imageFromMat(const cv::Mat& mat, const std::string& encoding, double stamp) {
  Image m;
  const double sec = std::floor(stamp);
  long long nsec = std::llround((stamp - sec) * 1e9);  // split first: stamp * 1e9 would lose nanoseconds
  const long long carry = nsec / 1000000000;
  m.header.stamp_sec = static_cast<uint32_t>(sec) + static_cast<uint32_t>(carry);
  m.header.stamp_nsec = static_cast<uint32_t>(nsec - carry * 1000000000);
  m.header.frame_id = "camera";
  m.encoding = encoding;
  cv::Mat out;  // a new matrix: converting into a header that shares `mat` would change the caller's image
  if (encoding == "rgb8")
    cv::cvtColor(mat, out, cv::COLOR_BGR2RGB);
  else
    out = mat;
  out = out.isContinuous() ? out : out.clone();
  m.height = static_cast<uint32_t>(out.rows);
  m.width = static_cast<uint32_t>(out.cols);
  m.step = static_cast<uint32_t>(out.cols * out.elemSize());
  m.data.assign(out.datastart, out.dataend);
  m.is_bigendian = hostIsBigEndian() ? 1 : 0;
  return m;
}

}  // namespace rgbdmap::ros1
