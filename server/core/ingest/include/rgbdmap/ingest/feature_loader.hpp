#pragma once
// The feature cache's loader: a stored keyframe record read back and its features rebuilt with the robot's
// camera. Called from the ingest or the optimiser thread without the ingest state lock (its own lock
// guards the cameras).
#include <map>
#include <mutex>
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/store/map_store.hpp"
#include "rgbdmap/vision/features.hpp"

namespace rgbdmap {

class FeatureLoader {
 public:
  /// Before the first load(): the opened store.
  void attach(const MapStore* store) { store_ = store; }
  void setCamera(const std::string& robot_id, const CameraIntrinsics& camera);
  Result<FrameFeatures> load(int64_t node_id) const;

 private:
  const MapStore* store_ = nullptr;
  mutable std::mutex mutex_;                         ///< cameras_
  std::map<std::string, CameraIntrinsics> cameras_;  ///< the robots' cameras
};

}  // namespace rgbdmap
