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

struct BagTopics {
  std::string rgb = "/camera/rgb/image_color";  ///< the TUM benchmark's topics
  std::string depth = "/camera/depth/image";
  std::string info = "/camera/rgb/camera_info";
  bool info_required =
      false;  ///< named explicitly: missing is an error (default: the camera comes elsewhere)
};

class BagReader : public ImageMessageReader {
 public:
  static Result<std::unique_ptr<BagReader>> open(const std::string& path, const BagTopics& topics);
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
