// mcap:FILE.mcap - colour, depth and camera_info of a rosbag2 MCAP recording (ROS 2 CDR sensor_msgs),
// paired by header stamp (paired_source.hpp). A first pass up to the first camera_info (or the first
// kInfoSearchColour colour images) checks the topics and reads the camera; the second pass yields the
// images. A recording cut off mid-write is read up to the cut, which is logged.
#include <map>

#include "paired_source.hpp"
#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/mcap/mcap_reader.hpp"
#include "rgbdmap/source/ros2_messages.hpp"
#include "rgbdmap/source/ros2_topics.hpp"
#include "sources.hpp"

namespace rgbdmap::source_detail {
namespace {

constexpr int kInfoSearchColour = 100;  // camera_info comes with the images; not searched past these

/// realsense2_camera (ROS 2) with align_depth.enable:=true.
ImageTopics realsenseTopics() {
  const ros2::CameraTopics t;
  return {t.rgb, t.depth, t.info, false};
}

std::string listTopics(const mcap::Reader& reader) {
  std::string out;
  for (const auto& [id, ch] : reader.channels()) {
    const mcap::Schema* s = reader.schemaOf(ch);
    out += (out.empty() ? "" : ", ") + ch.topic + " (" + (s ? s->name : "no schema") + ")";
  }
  return out.empty() ? "no topics" : out;
}

class McapImageReader : public ImageMessageReader {
 public:
  static Result<std::unique_ptr<McapImageReader>> open(const std::string& path, const ImageTopics& topics);

  Result<std::optional<ImageMessage>> next() override {
    using R = Result<std::optional<ImageMessage>>;
    for (;;) {
      Result<std::optional<mcap::Message>> m = reader_->next();
      if (!m) return R::failure(m.error());
      if (!*m) {
        if (reader_->cutOffAt() && !warned_) {
          warned_ = true;
          log::warn(describe(), ": the recording is cut off at byte ", *reader_->cutOffAt(), " of ",
                    reader_->fileSize(), " (no summary: it was not closed); read up to there");
        }
        return R(std::optional<ImageMessage>());
      }
      const mcap::Channel* ch = reader_->channel((*m)->channel_id);
      const bool color = ch->topic == topics_.rgb, depth = ch->topic == topics_.depth;
      if (!color && !depth) continue;
      if (Status s = checkChannel(*reader_, *ch); !s) return R::failure(describe() + ": " + s.error());
      Result<ros1::Image> image = ros2::decodeImage((*m)->data.data(), (*m)->data.size());
      if (!image) return R::failure(describe() + ": " + ch->topic + ": " + image.error());
      ImageMessage out;
      out.is_depth = depth;
      out.record_time = static_cast<double>((*m)->log_time) * 1e-9;
      out.image = std::move(*image);
      return R(std::optional<ImageMessage>(std::move(out)));
    }
  }
  const std::optional<CameraIntrinsics>& camera() const override { return camera_; }
  std::string describe() const override {
    return "mcap:" + path_ + " (colour " + topics_.rgb + ", depth " + topics_.depth + ")";
  }
  size_t colorCount() const override { return 0; }

  /// Empty when the channel carries CDR sensor_msgs/msg/`type` (or says nothing of its schema).
  static Status checkChannel(const mcap::Reader& reader, const mcap::Channel& ch,
                             const char* type = ros2::kImageType) {
    if (ch.message_encoding != "cdr")
      return Status::failure("topic " + ch.topic + " is encoded as '" + ch.message_encoding +
                             "', expected cdr");
    const mcap::Schema* s = reader.schemaOf(ch);
    if (s && s->name != type)
      return Status::failure("topic " + ch.topic + " is " + s->name + ", expected " + type);
    return Status::success();
  }

 private:
  McapImageReader() = default;
  Status scan(const ImageTopics& topics);

  std::string path_;
  ImageTopics topics_;
  std::unique_ptr<mcap::Reader> reader_;
  std::optional<CameraIntrinsics> camera_;
  bool warned_ = false;
};

/// The first pass: the first colour, depth and camera_info messages decode and convert.
Status McapImageReader::scan(const ImageTopics& topics) {
  auto reader = mcap::Reader::open(path_);
  if (!reader) return Status::failure(reader.error());
  std::optional<ros1::Image> color, depth;
  std::optional<ros1::CameraInfo> info;
  int colours = 0;
  while (!(color && depth && (info || colours >= kInfoSearchColour))) {
    Result<std::optional<mcap::Message>> m = (*reader)->next();
    if (!m) return Status::failure(m.error());
    if (!*m) break;
    const mcap::Channel& ch = *(*reader)->channel((*m)->channel_id);
    const bool is_image = ch.topic == topics.rgb || ch.topic == topics.depth;
    const bool is_info = !is_image && ch.topic == topics.info;
    if (!is_image && !is_info) continue;
    if (Status s = checkChannel(**reader, ch, is_info ? ros2::kCameraInfoType : ros2::kImageType); !s)
      return Status::failure(describe() + ": " + s.error());
    const auto& bytes = (*m)->data;
    if (is_info && !info) {
      auto decoded = ros2::decodeCameraInfo(bytes.data(), bytes.size());
      if (!decoded) return Status::failure(describe() + ": " + ch.topic + ": " + decoded.error());
      info = std::move(*decoded);
    } else if (!is_info) {
      colours += ch.topic == topics.rgb;
      auto& slot = ch.topic == topics.rgb ? color : depth;
      if (slot) continue;
      auto decoded = ros2::decodeImage(bytes.data(), bytes.size());
      if (!decoded) return Status::failure(describe() + ": " + ch.topic + ": " + decoded.error());
      slot = std::move(*decoded);
    }
  }
  for (const auto& [topic, option, found] : {std::tuple{topics.rgb, "rgb", color.has_value()},
                                             std::tuple{topics.depth, "depth", depth.has_value()}})
    if (!found)
      return Status::failure(describe() + ": no " + ros2::kImageType + " on " + topic +
                             " (choose another with ?" + option +
                             "=TOPIC; the file has: " + listTopics(**reader) + ")");
  if (auto c = ros1::colorFromImage(*color); !c)
    return Status::failure(describe() + ": colour: " + c.error());
  double depth_scale = 0;
  if (auto d = ros1::depthFromImage(*depth, &depth_scale); !d)
    return Status::failure(describe() + ": depth: " + d.error());
  if (info) {
    auto camera = ros1::cameraFromInfo(*info);
    if (!camera) return Status::failure(describe() + ": " + topics.info + ": " + camera.error());
    camera->depth_scale = depth_scale;
    camera_ = *camera;
  } else if (topics.info_required) {
    return Status::failure(describe() + ": no " + ros2::kCameraInfoType + " on " + topics.info +
                           " (the file has: " + listTopics(**reader) + ")");
  }
  return Status::success();
}

Result<std::unique_ptr<McapImageReader>> McapImageReader::open(const std::string& path,
                                                               const ImageTopics& topics) {
  using R = Result<std::unique_ptr<McapImageReader>>;
  std::unique_ptr<McapImageReader> r(new McapImageReader());
  r->path_ = path;
  r->topics_ = topics;
  if (Status s = r->scan(topics); !s) return R::failure(s.error());
  auto reader = mcap::Reader::open(path);
  if (!reader) return R::failure(reader.error());
  r->reader_ = std::move(*reader);
  return R(std::move(r));
}

}  // namespace

Result<std::unique_ptr<FrameSource>> openMcapSource(const SourceUrl& url, const SourceOptions& options) {
  using R = Result<std::unique_ptr<FrameSource>>;
  const ImageTopics topics = topicsFrom(url, realsenseTopics());
  Result<double> max_dt = maxTimeDiff(url, options);
  if (!max_dt) return R::failure(max_dt.error());
  auto reader = McapImageReader::open(url.path, topics);
  if (!reader) return R::failure(reader.error());
  return R(makePairedSource(std::move(*reader), *max_dt));
}

}  // namespace rgbdmap::source_detail
