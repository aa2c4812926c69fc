#pragma once
// Reader for RGB-D sequences in the TUM benchmark layout: rgb.txt and depth.txt list `timestamp filename`
// (lines starting with '#' are comments), images relative to the dataset folder, optional groundtruth.txt
// (TUM trajectory) and optional camera.yaml. Colour and depth are associated by nearest timestamp.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"
#include "rgbdmap/dataset/trajectory.hpp"

namespace rgbdmap {

struct DatasetOptions {
  double max_time_diff = 0.02;  ///< colour <-> depth association tolerance, seconds (TUM: 0.02)
  double depth_scale = 5000.0;  ///< metres = depth value / depth_scale (TUM: 5000); copied into each frame
  int expected_width = 640;     ///< images of another size are rejected; 0 accepts any width
  int expected_height = 480;    ///< 0 accepts any height

  /// Empty when valid, else the reasons.
  std::string validate() const;
};

/// One line of rgb.txt or depth.txt.
struct ImageListEntry {
  double timestamp = 0.0;  ///< seconds
  std::string path;        ///< as written in the list, relative to the dataset folder
};

/// One associated colour/depth pair.
struct FrameEntry {
  double rgb_timestamp = 0.0;
  std::string rgb_path;  ///< relative to the dataset folder
  double depth_timestamp = 0.0;
  std::string depth_path;
};

/// Parse an image list (`timestamp filename` per line). Errors read "<source_name>:<line>: reason".
Result<std::vector<ImageListEntry>> parseImageList(const std::string& text, const std::string& source_name);
Result<std::vector<ImageListEntry>> readImageList(const std::string& path);

/// Associate colour with depth (greedy nearest timestamp, each used once, |dt| < max_time_diff), sorted by
/// colour timestamp. Colour entries without depth are dropped.
std::vector<FrameEntry> associateImages(const std::vector<ImageListEntry>& rgb,
                                        const std::vector<ImageListEntry>& depth, double max_time_diff);

class TumDataset {
 public:
  /// Reads and associates the lists and the optional ground truth; images are read by load().
  static Result<TumDataset> open(const std::string& dir, const DatasetOptions& options = {});

  size_t size() const { return frames_.size(); }
  const FrameEntry& entry(size_t i) const { return frames_.at(i); }
  /// Reads frame i: colour as CV_8UC3 BGR (grey is expanded), depth as CV_16UC1, sizes checked.
  Result<RgbdFrame> load(size_t i) const;

  const std::optional<Trajectory>& groundTruth() const { return ground_truth_; }
  const std::string& dir() const { return dir_; }
  const DatasetOptions& options() const { return options_; }
  size_t rgbCount() const { return rgb_count_; }      ///< lines in rgb.txt
  size_t depthCount() const { return depth_count_; }  ///< lines in depth.txt
  /// Colour frames dropped because no depth image was within max_time_diff.
  size_t droppedRgbCount() const { return rgb_count_ - frames_.size(); }

 private:
  TumDataset() = default;
  std::string dir_;
  DatasetOptions options_;
  std::vector<FrameEntry> frames_;
  std::optional<Trajectory> ground_truth_;
  size_t rgb_count_ = 0;
  size_t depth_count_ = 0;
};

/// Reads `<dir>/camera.yaml` if present: `camera: {fx, fy, cx, cy, width, height, distortion: [k1, k2, p1,
/// p2, k3], depth_scale, readout_s}`. fx fy cx cy width height are required; a missing distortion means none,
/// a missing depth_scale means 5000, a missing readout_s the default rolling shutter (CameraIntrinsics).
/// nullopt when the file does not exist; an error (all problems listed) when it is malformed or fails
/// CameraIntrinsics::validate(). The caller decides how it combines with DatasetOptions.
Result<std::optional<CameraIntrinsics>> readDatasetCamera(const std::string& dir);
/// The text of a dataset's camera.yaml for `k` (what readDatasetCamera reads back exactly), after a comment
/// line `# <comment>`.
std::string datasetCameraYaml(const CameraIntrinsics& k, const std::string& comment);

}  // namespace rgbdmap
