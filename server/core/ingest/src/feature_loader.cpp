#include "rgbdmap/ingest/feature_loader.hpp"

#include <optional>

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/vision/keyframe_message.hpp"

namespace rgbdmap {

void FeatureLoader::setCamera(const std::string& robot_id, const CameraIntrinsics& camera) {
  std::lock_guard<std::mutex> lock(mutex_);
  cameras_.insert_or_assign(robot_id, camera);
}

Result<FrameFeatures> FeatureLoader::load(int64_t node_id) const {
  using R = Result<FrameFeatures>;
  if (!store_) return R::failure("no store");
  Result<StoredKeyframe> read = store_->readKeyframe(node_id);
  if (!read) return R::failure(read.error());
  std::optional<CameraIntrinsics> camera;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (const auto it = cameras_.find(read->keyframe.robot_id); it != cameras_.end()) camera = it->second;
  }
  if (!camera) return R::failure("no camera for robot " + read->keyframe.robot_id);
  Result<FrameFeatures> f = featuresFromMessage(read->keyframe, PinholeCamera(*camera));
  if (!f) log::error("server: features of keyframe ", node_id, " cannot be read back: ", f.error());
  return f;
}

}  // namespace rgbdmap
