// ros2:[?rgb=T&depth=T&info=T&domain=N&max_dt=S&wait=S] - colour, depth and camera_info from ROS 2 topics
// over Cyclone DDS (rmw_cyclonedds's wire format: common/ros2/idl/ros2_msgs.idl), paired by header stamp
// (paired_source.hpp). Opening waits (at most `wait` seconds) for a depth image, to know its encoding, and
// for camera_info; then samples are taken as they come, and the LatestFrameSource around a live source
// keeps only the newest pair. Readers are best-effort (they match reliable and best-effort publishers).
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <optional>
#include <thread>

#include "paired_source.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/source/ros2_topics.hpp"
#include "ros2_dds.hpp"
#include "sources.hpp"

namespace rgbdmap::source_detail {
namespace {

using ros2::ddsError;
using ros2::ddsTopicName;

struct Ros2Options {
  ImageTopics topics;
  int domain = 0;
  double wait_s = 10.0;
};

class DdsImageReader : public ImageMessageReader {
 public:
  static Result<std::unique_ptr<DdsImageReader>> open(const Ros2Options& options);
  ~DdsImageReader() override {
    if (participant_ > 0) dds_delete(participant_);
  }

  Result<std::optional<ImageMessage>> next() override {
    using R = Result<std::optional<ImageMessage>>;
    while (!closed_) {
      for (int k = 0; k < 2; ++k) {
        const bool depth = (turn_++ % 2) == 1;  // alternate, so that neither topic starves the other
        std::optional<ros1::Image> image;
        double sent = 0.0;
        if (Status s = take(depth ? depth_ : rgb_, &image, &sent); !s) {
          ++refused_;
          uint64_t suppressed = 0;
          if (limiter_.allow(&suppressed))
            log::warn(describe(), ": a sample refused: ", s.error(), " (", refused_, " so far)");
          continue;
        }
        if (!image) continue;
        ImageMessage m;
        m.is_depth = depth;
        m.record_time = sent;  // the pairing's stamp when the header has none
        m.image = std::move(*image);
        return R(std::optional<ImageMessage>(std::move(m)));
      }
      drainInfo();  // camera_info keeps coming with the images; the camera was fixed at open
      dds_waitset_wait(waitset_, nullptr, 0, DDS_MSECS(200));
    }
    return R(std::optional<ImageMessage>());
  }
  const std::optional<CameraIntrinsics>& camera() const override { return camera_; }
  std::string describe() const override {
    return "ros2: (colour " + options_.topics.rgb + ", depth " + options_.topics.depth + ", domain " +
           std::to_string(options_.domain) + ")";
  }
  size_t colorCount() const override { return 0; }
  bool live() const override { return true; }
  void close() override {
    closed_ = true;
    if (guard_ > 0) dds_set_guardcondition(guard_, true);
  }

 private:
  DdsImageReader() = default;
  Status create();
  Status waitForCamera();

  void drainInfo() {
    void* samples[8] = {nullptr};
    dds_sample_info_t info[8];
    const dds_return_t n = dds_take(info_, samples, info, 8, 8);
    if (n > 0) dds_return_loan(info_, samples, n);
  }

  /// One sample of `reader` (nullopt: none waiting) and when it was sent (s); the reason when it does not
  /// decode.
  static Status take(dds_entity_t reader, std::optional<ros1::Image>* out, double* sent) {
    void* samples[1] = {nullptr};
    dds_sample_info_t info[1];
    const dds_return_t n = dds_take(reader, samples, info, 1, 1);
    if (n <= 0) return Status::success();
    Status status = Status::success();
    if (info[0].valid_data) {
      *sent = static_cast<double>(info[0].source_timestamp) * 1e-9;
      auto image = ros2::detail::fromDds(*static_cast<const sensor_msgs_msg_dds__Image_*>(samples[0]));
      if (image)
        *out = std::move(*image);
      else
        status = Status::failure(image.error());
    }
    dds_return_loan(reader, samples, n);
    return status;
  }

  Ros2Options options_;
  dds_entity_t participant_ = 0, waitset_ = 0, guard_ = 0, rgb_ = 0, depth_ = 0, info_ = 0;
  std::optional<CameraIntrinsics> camera_;
  std::atomic<bool> closed_{false};
  unsigned turn_ = 0;
  uint64_t refused_ = 0;
  log::RateLimiter limiter_{1.0};
};

Status DdsImageReader::create() {
  participant_ = dds_create_participant(static_cast<dds_domainid_t>(options_.domain), nullptr, nullptr);
  if (participant_ < 0) return Status::failure(ddsError("dds_create_participant", participant_));
  waitset_ = dds_create_waitset(participant_);
  guard_ = dds_create_guardcondition(participant_);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_BEST_EFFORT, 0);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 4);
  auto reader = [&](const std::string& name, const dds_topic_descriptor_t* desc, dds_entity_t* out) {
    const dds_entity_t t = dds_create_topic(participant_, desc, ddsTopicName(name).c_str(), nullptr, nullptr);
    *out = t < 0 ? t : dds_create_reader(participant_, t, qos, nullptr);
    if (*out < 0) return false;
    // Unread samples only: a depth image read (not taken) while opening does not wake the waitset again.
    const dds_entity_t cond = dds_create_readcondition(
        *out, DDS_NOT_READ_SAMPLE_STATE | DDS_ANY_VIEW_STATE | DDS_ANY_INSTANCE_STATE);
    return cond >= 0 && dds_waitset_attach(waitset_, cond, 0) == 0;
  };
  const bool ok = waitset_ >= 0 && guard_ >= 0 && dds_waitset_attach(waitset_, guard_, 0) == 0 &&
                  reader(options_.topics.rgb, &sensor_msgs_msg_dds__Image__desc, &rgb_) &&
                  reader(options_.topics.depth, &sensor_msgs_msg_dds__Image__desc, &depth_) &&
                  reader(options_.topics.info, &sensor_msgs_msg_dds__CameraInfo__desc, &info_);
  dds_delete_qos(qos);
  return ok ? Status::success() : Status::failure(describe() + ": cannot create its DDS topics and readers");
}

/// Waits for the first camera_info and depth image (read, not taken: the depth image stays for next()).
Status DdsImageReader::waitForCamera() {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::duration<double>(options_.wait_s);
  std::optional<ros1::CameraInfo> info;
  std::optional<double> depth_scale;
  while ((!info || !depth_scale) && Clock::now() < deadline && !closed_) {
    if (!info) {
      void* samples[1] = {nullptr};
      dds_sample_info_t si[1];
      const dds_return_t n = dds_take(info_, samples, si, 1, 1);
      if (n > 0 && si[0].valid_data) {
        auto c = ros2::detail::fromDds(*static_cast<const sensor_msgs_msg_dds__CameraInfo_*>(samples[0]));
        if (c) info = std::move(*c);
      }
      if (n > 0) dds_return_loan(info_, samples, n);
    }
    if (!depth_scale) {
      void* samples[1] = {nullptr};
      dds_sample_info_t si[1];
      const dds_return_t n = dds_read(depth_, samples, si, 1, 1);
      if (n > 0 && si[0].valid_data) {
        auto image = ros2::detail::fromDds(*static_cast<const sensor_msgs_msg_dds__Image_*>(samples[0]));
        double scale = 0;
        if (image && ros1::depthFromImage(*image, &scale)) depth_scale = scale;
        if (image && !depth_scale)
          return dds_return_loan(depth_, samples, n),
                 Status::failure(describe() + ": depth: " + ros1::depthFromImage(*image, &scale).error());
      }
      if (n > 0) dds_return_loan(depth_, samples, n);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // colour waiting would keep a waitset awake
  }
  if (!depth_scale)
    return Status::failure(describe() + ": no depth image on " + options_.topics.depth + " within " +
                           std::to_string(static_cast<int>(options_.wait_s)) +
                           " s (is the camera publishing, in this DDS domain and CYCLONEDDS_URI's network?)");
  if (info) {
    auto camera = ros1::cameraFromInfo(*info);
    if (!camera) return Status::failure(describe() + ": " + options_.topics.info + ": " + camera.error());
    camera->depth_scale = *depth_scale;
    camera_ = *camera;
  } else if (options_.topics.info_required) {
    return Status::failure(describe() + ": no camera_info on " + options_.topics.info);
  }
  return Status::success();
}

Result<std::unique_ptr<DdsImageReader>> DdsImageReader::open(const Ros2Options& options) {
  using R = Result<std::unique_ptr<DdsImageReader>>;
  if (Status s = ros2::checkDdsConfiguration(); !s) return R::failure("ros2: " + s.error());
  std::unique_ptr<DdsImageReader> r(new DdsImageReader());
  r->options_ = options;
  if (Status s = r->create(); !s) return R::failure(s.error());
  if (Status s = r->waitForCamera(); !s) return R::failure(s.error());
  return R(std::move(r));
}

Result<double> seconds(const SourceUrl& url, const std::string& key, double fallback, double max) {
  if (!url.query.count(key)) return fallback;
  char* end = nullptr;
  const std::string text = url.get(key, "");
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(v > 0 && v <= max))
    return Result<double>::failure("ros2: " + key + " must be in (0, " +
                                   std::to_string(static_cast<int>(max)) + "]");
  return v;
}

}  // namespace

Result<std::unique_ptr<FrameSource>> openRos2Source(const SourceUrl& url, const SourceOptions& options) {
  using R = Result<std::unique_ptr<FrameSource>>;
  Ros2Options o;
  const ros2::CameraTopics defaults;
  o.topics = topicsFrom(url, {defaults.rgb, defaults.depth, defaults.info, false});
  const std::string domain = url.get("domain", "0");
  char* end = nullptr;
  const long d = std::strtol(domain.c_str(), &end, 10);
  if (domain.empty() || *end != '\0' || d < 0 || d > 232) return R::failure("ros2: domain must be 0..232");
  o.domain = static_cast<int>(d);
  Result<double> wait = seconds(url, "wait", o.wait_s, 3600.0);
  if (!wait) return R::failure(wait.error());
  o.wait_s = *wait;
  Result<double> max_dt = maxTimeDiff(url, options);
  if (!max_dt) return R::failure(max_dt.error());
  auto reader = DdsImageReader::open(o);
  if (!reader) return R::failure(reader.error());
  return R(makePairedSource(std::move(*reader), *max_dt));
}

}  // namespace rgbdmap::source_detail
