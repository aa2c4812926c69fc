// rosbag_storage behind BagReader (its headers stay in this file).
#include "bag_reader.hpp"

#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <filesystem>
#include <map>

namespace rgbdmap::source_detail {

struct BagReader::Impl {
  std::string path;
  ImageTopics topics;
  rosbag::Bag bag;
  std::unique_ptr<rosbag::View> view;
  rosbag::View::iterator it;
};

namespace {

std::vector<uint8_t> bytesOf(const rosbag::MessageInstance& m) {
  std::vector<uint8_t> bytes(m.size());
  ros::serialization::OStream stream(bytes.data(), static_cast<uint32_t>(bytes.size()));
  m.write(stream);
  return bytes;
}

/// Every topic with its type, for the error messages.
std::map<std::string, std::string> topicTypes(const rosbag::Bag& bag) {
  rosbag::View all(bag);
  std::map<std::string, std::string> types;
  for (const rosbag::ConnectionInfo* c : all.getConnections()) types[c->topic] = c->datatype;
  return types;
}

std::string listTopics(const std::map<std::string, std::string>& types) {
  std::string out;
  for (const auto& [topic, type] : types) out += (out.empty() ? "" : ", ") + topic + " (" + type + ")";
  return out.empty() ? "none" : out;
}

/// Empty when `topic` is there with `type`, else the reason.
std::string checkTopic(const std::map<std::string, std::string>& types, const std::string& topic,
                       const char* type, const char* option) {
  const auto it = types.find(topic);
  if (it == types.end())
    return std::string("no topic ") + topic + " (choose another with ?" + option +
           "=TOPIC; the bag has: " + listTopics(types) + ")";
  if (it->second != type) return "topic " + topic + " is " + it->second + ", expected " + type;
  return "";
}

/// The first message on `topic` decoded, to check the encoding (or read the camera) before running.
template <typename Message, typename Decode>
Result<Message> firstMessage(const rosbag::Bag& bag, const std::string& topic, Decode decode) {
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  if (view.begin() == view.end()) return Result<Message>::failure("topic " + topic + " has no messages");
  const std::vector<uint8_t> bytes = bytesOf(*view.begin());
  auto m = decode(bytes.data(), bytes.size());
  if (!m) return Result<Message>::failure("topic " + topic + ": " + m.error());
  return std::move(*m);
}

}  // namespace

BagReader::BagReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
BagReader::~BagReader() = default;

std::string BagReader::describe() const {
  return "bag:" + impl_->path + " (colour " + impl_->topics.rgb + ", depth " + impl_->topics.depth + ")";
}

Result<std::unique_ptr<BagReader>> BagReader::open(const std::string& path, const ImageTopics& topics) {
  using R = Result<std::unique_ptr<BagReader>>;
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  impl->topics = topics;
  const std::string name = "bag " + path + ": ";
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return R::failure(name + "no such file");
  try {
    impl->bag.open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    return R::failure(name + "cannot read: " + e.what() +
                      " (truncated or unindexed - a recording that was cut off; `rosbag reindex " + path +
                      "` (python3-rosbag) repairs that - or not a ROS 1 bag)");
  }
  std::unique_ptr<BagReader> reader(new BagReader(std::move(impl)));
  try {
    Impl& b = *reader->impl_;
    const auto types = topicTypes(b.bag);
    for (const auto& [topic, option] : {std::pair{topics.rgb, "rgb"}, std::pair{topics.depth, "depth"}})
      if (std::string e = checkTopic(types, topic, ros1::kImageType, option); !e.empty())
        return R::failure(name + e);
    auto color = firstMessage<ros1::Image>(b.bag, topics.rgb, ros1::decodeImage);
    if (!color) return R::failure(name + color.error());
    if (auto c = ros1::colorFromImage(*color); !c) return R::failure(name + topics.rgb + ": " + c.error());
    auto depth = firstMessage<ros1::Image>(b.bag, topics.depth, ros1::decodeImage);
    if (!depth) return R::failure(name + depth.error());
    double depth_scale = 0;
    if (auto d = ros1::depthFromImage(*depth, &depth_scale); !d)
      return R::failure(name + topics.depth + ": " + d.error());
    if (std::string e = checkTopic(types, topics.info, ros1::kCameraInfoType, "info"); e.empty()) {
      auto info = firstMessage<ros1::CameraInfo>(b.bag, topics.info, ros1::decodeCameraInfo);
      if (!info) return R::failure(name + info.error());
      auto camera = ros1::cameraFromInfo(*info);
      if (!camera) return R::failure(name + topics.info + ": " + camera.error());
      camera->depth_scale = depth_scale;
      reader->camera_ = *camera;
    } else if (topics.info_required) {
      return R::failure(name + e);
    }
    reader->color_count_ = rosbag::View(b.bag, rosbag::TopicQuery(topics.rgb)).size();
    b.view = std::make_unique<rosbag::View>(
        b.bag, rosbag::TopicQuery(std::vector<std::string>{topics.rgb, topics.depth}));
    b.it = b.view->begin();
  } catch (const std::exception& e) {
    return R::failure(name + "cannot read: " + e.what());
  }
  return R(std::move(reader));
}

Result<std::optional<ImageMessage>> BagReader::next() {
  using R = Result<std::optional<ImageMessage>>;
  Impl& b = *impl_;
  try {
    if (b.it == b.view->end()) return R(std::nullopt);
    const rosbag::MessageInstance& m = *b.it;
    ImageMessage out;
    out.is_depth = m.getTopic() == b.topics.depth;
    out.record_time = m.getTime().toSec();
    const std::vector<uint8_t> bytes = bytesOf(m);
    auto image = ros1::decodeImage(bytes.data(), bytes.size());
    if (!image) return R::failure("bag " + b.path + ": " + m.getTopic() + ": " + image.error());
    out.image = std::move(*image);
    ++b.it;
    return R(std::move(out));
  } catch (const std::exception& e) {
    return R::failure("bag " + b.path + ": cannot read on: " + e.what() + " (truncated or corrupt?)");
  }
}

}  // namespace rgbdmap::source_detail
