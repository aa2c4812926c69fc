// A recording's colour and depth messages (ImageMessageReader: ROS 1 bags, MCAP) as frames: one pass in
// time order, colour and depth paired by header stamp as they come; at most a few images are held at once,
// whatever the recording's size.
#include "paired_source.hpp"

#include <cmath>
#include <cstdlib>
#include <deque>

namespace rgbdmap::source_detail {
namespace {

struct Stamped {
  double stamp = 0.0;
  size_t index = 0;  ///< colour: its position among the colour messages
  cv::Mat image;
  double depth_scale = 0.0;
  std::string error;  ///< set: the message could not be decoded
};

class PairedSource : public FrameSource {
 public:
  PairedSource(std::unique_ptr<ImageMessageReader> reader, double max_dt)
      : reader_(std::move(reader)), max_dt_(max_dt) {}

  FrameRead next() override {
    for (;;) {
      if (std::optional<FrameRead> paired = pairFront()) return std::move(*paired);
      if (ended_) return drainEnd();
      Result<std::optional<ImageMessage>> message = reader_->next();
      if (!message) return FrameRead::failed(message.error());
      if (!*message) {
        ended_ = true;
        continue;
      }
      if (Status s = take(std::move(**message)); !s) return FrameRead::failed(s.error());
    }
  }
  bool live() const override { return reader_->live(); }
  void close() override { reader_->close(); }
  std::optional<CameraIntrinsics> camera() const override { return reader_->camera(); }
  std::string describe() const override { return reader_->describe(); }
  size_t sizeHint() const override { return reader_->colorCount(); }

 private:
  Status take(ImageMessage message) {
    constexpr size_t kMaxWaiting = 32;  // one topic stalled: drop its partner's oldest, never grow
    for (auto* q : {&color_, &depth_})
      if (q->size() >= kMaxWaiting) q->pop_front();
    Stamped s;
    s.stamp = message.image.header.stamp();
    if (s.stamp == 0.0) s.stamp = message.record_time;
    if (message.is_depth) {
      auto depth = ros1::depthFromImage(message.image, &s.depth_scale);
      if (!depth) return Status::failure(reader_->describe() + ": depth: " + depth.error());
      s.image = std::move(*depth);
      depth_.push_back(std::move(s));
    } else {
      s.index = color_index_++;
      auto color = ros1::colorFromImage(message.image);
      if (!color) return Status::failure(reader_->describe() + ": colour: " + color.error());
      s.image = std::move(*color);
      color_.push_back(std::move(s));
    }
    return Status::success();
  }

  /// A pair when the front colour and depth are each other's nearest (needs one more of each to know,
  /// unless the bag has ended); drops a front message that cannot be paired any more.
  std::optional<FrameRead> pairFront() {
    while (!color_.empty() && !depth_.empty()) {
      const Stamped& c = color_.front();
      const Stamped& d = depth_.front();
      if (c.stamp < d.stamp - max_dt_) {
        color_.pop_front();  // colour without depth (TUM's association drops it too)
        continue;
      }
      if (d.stamp < c.stamp - max_dt_) {
        depth_.pop_front();
        continue;
      }
      const bool more = ended_ || (color_.size() > 1 && depth_.size() > 1);
      if (!more) return std::nullopt;
      if (depth_.size() > 1 && std::abs(depth_[1].stamp - c.stamp) < std::abs(d.stamp - c.stamp)) {
        depth_.pop_front();
        continue;
      }
      if (color_.size() > 1 && std::abs(color_[1].stamp - d.stamp) < std::abs(c.stamp - d.stamp)) {
        color_.pop_front();
        continue;
      }
      return makeFrame();
    }
    return std::nullopt;
  }

  FrameRead makeFrame() {
    RgbdFrame f;
    f.timestamp = color_.front().stamp;
    f.color = std::move(color_.front().image);
    f.depth = std::move(depth_.front().image);
    f.depth_scale = depth_.front().depth_scale;
    const size_t index = color_.front().index;
    color_.pop_front();
    depth_.pop_front();
    if (f.color.size() != f.depth.size())
      return FrameRead::unreadable(index, "colour " + std::to_string(f.color.cols) + "x" +
                                              std::to_string(f.color.rows) + " and depth " +
                                              std::to_string(f.depth.cols) + "x" +
                                              std::to_string(f.depth.rows) + " differ in size");
    return FrameRead::ok(index, std::move(f));
  }

  FrameRead drainEnd() {
    color_.clear();
    depth_.clear();
    return FrameRead::end();
  }

  std::unique_ptr<ImageMessageReader> reader_;
  double max_dt_;
  bool ended_ = false;
  size_t color_index_ = 0;
  std::deque<Stamped> color_, depth_;
};

}  // namespace

ImageTopics topicsFrom(const SourceUrl& url, ImageTopics defaults) {
  defaults.rgb = url.get("rgb", defaults.rgb);
  defaults.depth = url.get("depth", defaults.depth);
  defaults.info = url.get("info", defaults.info);
  defaults.info_required = url.query.count("info") > 0;
  return defaults;
}

Result<double> maxTimeDiff(const SourceUrl& url, const SourceOptions& options) {
  if (!url.query.count("max_dt")) return options.max_time_diff;
  char* end = nullptr;
  const std::string text = url.get("max_dt", "");
  const double max_dt = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(max_dt > 0 && max_dt < 10))
    return Result<double>::failure(url.scheme + ":" + url.path + ": max_dt must be seconds in (0, 10)");
  return max_dt;
}

std::unique_ptr<FrameSource> makePairedSource(std::unique_ptr<ImageMessageReader> reader, double max_dt) {
  return std::make_unique<PairedSource>(std::move(reader), max_dt);
}

}  // namespace rgbdmap::source_detail
