// openni2:[URI] - a live OpenNI2 camera (Kinect v1, Xtion, Astra-class): 640x480 colour and depth at 30 Hz,
// depth registered to colour by the device, frames paired by the device's sync, intrinsics from its fields
// of view. Nothing here prints: every failure is a reason naming what was tried.
#include <OpenNI.h>

#include <atomic>
#include <cctype>
#include <cmath>
#include <mutex>

#include <opencv2/imgproc.hpp>

#include "sources.hpp"

namespace rgbdmap::source_detail {
namespace {

constexpr int kWidth = 640, kHeight = 480, kFps = 30;
constexpr int kWaitMs = 200;  ///< next() polls the streams in slices this long so close() is noticed

/// `what` and OpenNI2's last error, whitespace trimmed (it starts with a tab).
std::string oniError(const std::string& what) {
  std::string e = openni::OpenNI::getExtendedError();
  const size_t first = e.find_first_not_of(" \t\r\n");
  e = first == std::string::npos ? std::string() : e.substr(first);
  while (!e.empty() && std::isspace(static_cast<unsigned char>(e.back()))) e.pop_back();
  return what + (e.empty() ? std::string() : ": " + e);
}

std::string oniVersion() {
  const openni::Version v = openni::OpenNI::getVersion();
  return "OpenNI2 " + std::to_string(v.major) + "." + std::to_string(v.minor) + "." +
         std::to_string(v.maintenance);
}

/// Sets 640x480@30 in `format`; the reason when the device has no such mode.
std::string setMode(openni::VideoStream& stream, openni::PixelFormat format, const char* name) {
  openni::VideoMode mode;
  mode.setResolution(kWidth, kHeight);
  mode.setFps(kFps);
  mode.setPixelFormat(format);
  if (stream.setVideoMode(mode) != openni::STATUS_OK) return oniError(std::string(name) + " 640x480@30");
  return "";
}

class OpenNi2Source : public FrameSource {
 public:
  ~OpenNi2Source() override {
    color_.stop();
    depth_.stop();
    color_.destroy();
    depth_.destroy();
    device_.close();
    openni::OpenNI::shutdown();
  }

  /// Opens the device and starts both streams; the reason when it cannot.
  std::string start(const std::string& uri) {
    if (openni::OpenNI::initialize() != openni::STATUS_OK) return oniError("OpenNI2 initialise");
    openni::Array<openni::DeviceInfo> devices;
    openni::OpenNI::enumerateDevices(&devices);
    uri_ = uri;
    const std::string tried =
        oniVersion() + " with its drivers (PS1080: Kinect v1, Xtion, Carmine; OniFile: .oni)";
    if (uri.empty() && devices.getSize() == 0)
      return "no RGB-D camera found by " + tried +
             "; is one plugged in, powered, and its USB device readable "
             "by this user?";
    if (device_.open(uri.empty() ? openni::ANY_DEVICE : uri.c_str()) != openni::STATUS_OK)
      return oniError("cannot open '" + (uri.empty() ? std::string("the first device") : uri) + "' with " +
                      tried + " (" + std::to_string(devices.getSize()) + " devices found)");
    if (color_.create(device_, openni::SENSOR_COLOR) != openni::STATUS_OK) return oniError("colour stream");
    if (depth_.create(device_, openni::SENSOR_DEPTH) != openni::STATUS_OK) return oniError("depth stream");
    if (auto e = setMode(color_, openni::PIXEL_FORMAT_RGB888, "colour"); !e.empty()) return e;
    if (auto e = setMode(depth_, openni::PIXEL_FORMAT_DEPTH_1_MM, "depth"); !e.empty()) return e;
    if (!device_.isImageRegistrationModeSupported(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) ||
        device_.setImageRegistrationMode(openni::IMAGE_REGISTRATION_DEPTH_TO_COLOR) != openni::STATUS_OK)
      return oniError("depth-to-colour registration");
    device_.setDepthColorSyncEnabled(true);  // best effort: pairing below also checks the timestamps
    if (color_.start() != openni::STATUS_OK) return oniError("start colour");
    if (depth_.start() != openni::STATUS_OK) return oniError("start depth");
    camera_ = intrinsics();
    return "";
  }

  FrameRead next() override {
    openni::VideoFrameRef color, depth;
    while (!closed_) {
      openni::VideoStream* streams[] = {&color_, &depth_};
      int ready = -1;
      const openni::Status s = openni::OpenNI::waitForAnyStream(streams, 2, &ready, kWaitMs);
      if (s == openni::STATUS_TIME_OUT) continue;
      if (s != openni::STATUS_OK) return FrameRead::failed(oniError("openni2:" + uri_ + ": lost the camera"));
      if (streams[ready]->readFrame(ready == 0 ? &color : &depth) != openni::STATUS_OK)
        return FrameRead::failed(oniError("read frame"));
      if (!color.isValid() || !depth.isValid()) continue;
      const double dt_us = std::abs(static_cast<double>(color.getTimestamp()) - depth.getTimestamp());
      if (dt_us > 20000) continue;  // not a pair yet: wait for the partner of the newer one
      return FrameRead::ok(index_++, toFrame(color, depth));
    }
    return FrameRead::end();
  }
  bool live() const override { return true; }
  std::optional<CameraIntrinsics> camera() const override { return camera_; }
  std::string describe() const override { return "openni2:" + uri_; }
  void close() override { closed_ = true; }

 private:
  CameraIntrinsics intrinsics() const {
    CameraIntrinsics c;
    c.width = kWidth;
    c.height = kHeight;
    c.fx = kWidth / (2.0 * std::tan(color_.getHorizontalFieldOfView() / 2.0));
    c.fy = kHeight / (2.0 * std::tan(color_.getVerticalFieldOfView() / 2.0));
    c.cx = kWidth / 2.0 - 0.5;
    c.cy = kHeight / 2.0 - 0.5;
    c.distortion.fill(0.0);
    c.depth_scale = 1000.0;  // DEPTH_1_MM
    return c;
  }

  RgbdFrame toFrame(const openni::VideoFrameRef& color, const openni::VideoFrameRef& depth) {
    RgbdFrame f;
    if (!t0_us_) {
      t0_us_ = color.getTimestamp();
      wall0_s_ = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    }
    f.timestamp =
        wall0_s_ + (static_cast<double>(color.getTimestamp()) - static_cast<double>(*t0_us_)) * 1e-6;
    const cv::Mat rgb(color.getHeight(), color.getWidth(), CV_8UC3, const_cast<void*>(color.getData()),
                      static_cast<size_t>(color.getStrideInBytes()));
    cv::cvtColor(rgb, f.color, cv::COLOR_RGB2BGR);
    f.depth = cv::Mat(depth.getHeight(), depth.getWidth(), CV_16UC1, const_cast<void*>(depth.getData()),
                      static_cast<size_t>(depth.getStrideInBytes()))
                  .clone();
    f.depth_scale = 1000.0;
    return f;
  }

  openni::Device device_;
  openni::VideoStream color_, depth_;
  std::string uri_;
  std::optional<CameraIntrinsics> camera_;
  std::atomic<bool> closed_{false};
  size_t index_ = 0;
  std::optional<uint64_t> t0_us_;
  double wall0_s_ = 0.0;
};

}  // namespace

Result<std::unique_ptr<FrameSource>> openOpenni2Source(const SourceUrl& url, const SourceOptions&) {
  using R = Result<std::unique_ptr<FrameSource>>;
  auto source = std::make_unique<OpenNi2Source>();
  if (std::string e = source->start(url.path); !e.empty())
    return R::failure("openni2:" + url.path + (url.path.empty() ? "" : ":") + " " + e);
  return R(std::move(source));
}

}  // namespace rgbdmap::source_detail
