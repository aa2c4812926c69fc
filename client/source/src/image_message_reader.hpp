#pragma once
// What a recording's reader gives the paired source (paired_source.hpp): colour and depth image messages
// in time order and the camera, whatever the container (ROS 1 bag, MCAP).
#include <optional>
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/source/ros_messages.hpp"

namespace rgbdmap::source_detail {

/// The topics of a recording or a live ROS graph that a source reads.
struct ImageTopics {
  std::string rgb, depth, info;
  bool info_required = false;  ///< named explicitly (?info=): missing is an error
};

struct ImageMessage {
  bool is_depth = false;
  double record_time = 0.0;  ///< when it was recorded (s); the pairing's stamp when the header has none
  ros1::Image image;
};

class ImageMessageReader {
 public:
  virtual ~ImageMessageReader() = default;
  /// The next colour or depth message; nullopt at the end; the reason when the file cannot be read on.
  virtual Result<std::optional<ImageMessage>> next() = 0;
  virtual const std::optional<CameraIntrinsics>& camera() const = 0;
  virtual std::string describe() const = 0;
  /// Colour messages in the file when it says (0: unknown).
  virtual size_t colorCount() const = 0;
  /// true: a live stream (ROS 2 topics), false: a recording.
  virtual bool live() const { return false; }
  /// Asks a blocking next() to end soon (from another thread).
  virtual void close() {}
};

}  // namespace rgbdmap::source_detail
