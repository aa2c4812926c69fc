#pragma once
// Where a robot's RGB-D frames come from: a TUM or 7-Scenes folder, a ROS 1 or ROS 2 bag, live ROS 2 topics,
// a live OpenNI2 camera.
// Every source yields timestamped colour + depth frames registered to each other, with the camera model
// when the source knows it; it says whether it is live (a camera: frames come at the sensor's rate whether
// or not anyone reads them) and it can end. The odometry library knows nothing of sources; the programs
// and the robot run loop pull frames through this interface.
#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"
#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"

namespace rgbdmap {

/// One pull from a source.
struct FrameRead {
  enum class Kind {
    kFrame,       ///< `frame` holds the next frame
    kUnreadable,  ///< frame `index` could not be read (missing, corrupt, wrong size): skip it and go on
    kEnd,         ///< no more frames (end of the recording, or the source was closed)
    kFailed,      ///< the source cannot go on (device lost, truncated bag): `error` says why
  };
  Kind kind = Kind::kEnd;
  size_t index = 0;  ///< position of this frame in the source (frames and unreadable ones)
  RgbdFrame frame;   ///< colour CV_8UC3 BGR, depth CV_16UC1 in frame.depth_scale units per metre
  std::string error;

  static FrameRead end() { return {}; }
  static FrameRead failed(std::string why) { return {Kind::kFailed, 0, {}, std::move(why)}; }
  static FrameRead unreadable(size_t index, std::string why) {
    return {Kind::kUnreadable, index, {}, std::move(why)};
  }
  static FrameRead ok(size_t index, RgbdFrame frame) { return {Kind::kFrame, index, std::move(frame), {}}; }
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;

  /// Blocks until the next frame (live sources: until the sensor delivers one).
  virtual FrameRead next() = 0;
  /// true: frames arrive at the sensor's rate and are never waited for (a camera); false: a recording,
  /// read at whatever rate the reader wants.
  virtual bool live() const = 0;
  /// The camera model the source carries (camera.yaml, camera_info, the device); nullopt when it has none.
  virtual std::optional<CameraIntrinsics> camera() const = 0;
  /// What it reads, for logs ("bag:x.bag (rgb /camera/rgb/image_color, depth /camera/depth/image)").
  virtual std::string describe() const = 0;
  /// Frames known in advance (recordings), 0 when unknown (live).
  virtual size_t sizeHint() const { return 0; }
  /// Frames the source produced that nobody read in time (live sources behind a LatestFrameSource).
  virtual size_t droppedFrames() const { return 0; }
  /// Ground truth, when the recording has one (TUM groundtruth.txt).
  virtual std::optional<Trajectory> groundTruth() const { return std::nullopt; }
  /// Asks a blocking next() to return kEnd soon (from another thread, e.g. on SIGINT). Default: nothing.
  virtual void close() {}
};

/// A parsed --source URL: `scheme:path?key=value&key2=value2`.
struct SourceUrl {
  std::string scheme;  ///< tum | 7scenes | bag | mcap | ros2 | openni2
  std::string path;    ///< folder, file or device URI (may be empty for openni2)
  std::map<std::string, std::string> query;

  /// Parses and checks the scheme and the keys it allows; the reason when malformed.
  static Result<SourceUrl> parse(const std::string& url);
  std::string get(const std::string& key, const std::string& fallback) const {
    const auto it = query.find(key);
    return it == query.end() ? fallback : it->second;
  }
};

/// What the programs' configuration says about reading sources.
struct SourceOptions {
  double max_time_diff = 0.02;  ///< colour <-> depth pairing tolerance, seconds
  double depth_scale = 5000.0;  ///< TUM folders: raw units per metre (bags and devices carry their own)
  int expected_width = 640;     ///< TUM folders: images of another size are unreadable; 0 = any
  int expected_height = 480;
  size_t first_frame = 0;    ///< frames before this one are skipped (read, not returned)
  long long end_frame = -1;  ///< exclusive; -1 = until the source ends
};

/// Opens the source `url` names (see SourceUrl). The reason, naming what was tried, when it cannot.
Result<std::unique_ptr<FrameSource>> openFrameSource(const SourceUrl& url, const SourceOptions& options);

/// Frames [first, end) (end -1: all) of an opened TUM dataset as a source (what tum:DIR opens).
std::unique_ptr<FrameSource> makeTumSource(TumDataset dataset, size_t first = 0, long long end = -1);

/// The URL forms, for usage texts.
const char* sourceUrlHelp();

}  // namespace rgbdmap
