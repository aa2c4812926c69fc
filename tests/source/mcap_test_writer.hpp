#pragma once
// Writes RGB-D frames into a rosbag2-style MCAP file with the project's writer (ROS 2 CDR sensor_msgs, the
// realsense2_camera topics by default), to test the mcap: source. Test-only; the reference implementation
// (@mcap/core) writes its own files in tests/cli/test_mcap_sources.sh.
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/mcap/mcap.hpp"

namespace rgbdmap::testing {

struct McapWriteOptions {
  std::string color_encoding = "bgr8";   ///< rgb8 | bgr8 | mono8
  std::string depth_encoding = "32FC1";  ///< 32FC1 metres | 16UC1 millimetres
  std::string rgb_topic = "/camera/camera/color/image_raw";
  std::string depth_topic = "/camera/camera/aligned_depth_to_color/image_raw";
  std::string info_topic = "/camera/camera/color/camera_info";
  bool write_info = true;
  mcap::Compression compression = mcap::Compression::kZstd;
  size_t chunk_bytes = size_t{1} << 20;  ///< 0 with kNone: no chunks
  size_t max_frames = 0;                 ///< 0: all
};

Status writeTumFolderAsMcap(const std::string& dir, const std::string& mcap_path,
                            const CameraIntrinsics& camera, const McapWriteOptions& options);

}  // namespace rgbdmap::testing
