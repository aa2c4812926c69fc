#pragma once
// The rosbag_storage side of the bag source: opens the bag, checks its topics and types, reads the
// camera_info, and yields the colour and depth image messages in time order. Every rosbag exception ends
// here as a reason naming the bag.
#include <memory>
#include <optional>
#include <string>

#include "image_message_reader.hpp"
#include "rgbdmap/common/result.hpp"

namespace rgbdmap::source_detail {

/// The TUM benchmark's topics, the bag source's defaults.
inline ImageTopics tumBagTopics() {
  return {"/camera/rgb/image_color", "/camera/depth/image", "/camera/rgb/camera_info", false};
}

class BagReader : public ImageMessageReader {
 public:
  static Result<std::unique_ptr<BagReader>> open(const std::string& path, const ImageTopics& topics);
  ~BagReader() override;
  Result<std::optional<ImageMessage>> next() override;
  const std::optional<CameraIntrinsics>& camera() const override { return camera_; }
  std::string describe() const override;
  size_t colorCount() const override { return color_count_; }

 private:
  struct Impl;
  explicit BagReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  std::optional<CameraIntrinsics> camera_;
  size_t color_count_ = 0;
};

}  // namespace rgbdmap::source_detail
