#pragma once
// Writes RGB-D frames into a ROS 1 bag with the real rosbag_storage writer, in the TUM benchmark's topics
// and encodings (or others, to test the reader's choices and its errors). Test-only.
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"

namespace rgbdmap::testing {

struct BagWriteOptions {
  std::string color_encoding = "rgb8";   ///< rgb8 | bgr8 | mono8 (or anything, for error tests)
  std::string depth_encoding = "32FC1";  ///< 32FC1 metres | 16UC1 millimetres (or anything)
  std::string rgb_topic = "/camera/rgb/image_color";
  std::string depth_topic = "/camera/depth/image";
  std::string info_topic = "/camera/rgb/camera_info";
  bool write_depth = true;
  bool write_info = true;
  std::string compression = "none";  ///< none | bz2 (as the TUM benchmark's bags) | lz4
  size_t max_frames = 0;             ///< 0: all
};

/// Every frame of the TUM folder `dir` (read with `camera`'s depth scale and size) into `bag_path`: colour
/// and depth at their own stamps, camera_info with each colour image.
Status writeTumFolderAsBag(const std::string& dir, const std::string& bag_path,
                           const CameraIntrinsics& camera, const BagWriteOptions& options);

}  // namespace rgbdmap::testing
