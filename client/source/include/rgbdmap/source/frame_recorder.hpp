#pragma once
// Writes frames as a TUM-layout folder that tum:DIR (or --dataset DIR) replays exactly: rgb/<t>.png,
// depth/<t>.png (16-bit, the frame's raw units), rgb.txt, depth.txt, camera.yaml (with the depth scale) and,
// when known, groundtruth.txt. Every file is written atomically; the lists are rewritten every
// kListEvery frames and at finish(), so a killed recording still replays up to the last rewrite.
#include <memory>
#include <string>

#include "rgbdmap/common/camera.hpp"
#include "rgbdmap/common/result.hpp"
#include "rgbdmap/common/rgbd_frame.hpp"
#include "rgbdmap/dataset/trajectory.hpp"
#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap {

class TumRecorder {
 public:
  static constexpr size_t kListEvery = 100;

  /// Creates dir, dir/rgb and dir/depth; the reason when it cannot.
  static Result<TumRecorder> create(const std::string& dir, const CameraIntrinsics& camera);
  Status add(const RgbdFrame& frame);
  /// Lists, camera.yaml, optional ground truth, then the folders synced.
  Status finish(const std::optional<Trajectory>& ground_truth = std::nullopt);
  size_t frames() const { return lines_; }
  const std::string& dir() const { return dir_; }

 private:
  Status writeLists() const;
  std::string dir_;
  CameraIntrinsics camera_;
  std::string rgb_list_, depth_list_;
  size_t lines_ = 0;
};

/// Passes frames through and records each one it returns (what the reader consumed). A frame that cannot
/// be recorded ends the source with kFailed (a recording with holes would not replay the session).
class RecordingSource : public FrameSource {
 public:
  RecordingSource(std::unique_ptr<FrameSource> inner, TumRecorder recorder);
  FrameRead next() override;
  bool live() const override { return inner_->live(); }
  std::optional<CameraIntrinsics> camera() const override { return inner_->camera(); }
  std::string describe() const override { return inner_->describe(); }
  size_t sizeHint() const override { return inner_->sizeHint(); }
  size_t droppedFrames() const override { return inner_->droppedFrames(); }
  std::optional<Trajectory> groundTruth() const override { return inner_->groundTruth(); }
  void close() override { inner_->close(); }
  /// Writes the lists and syncs; call once after the last next().
  Status finish() { return recorder_.finish(inner_->groundTruth()); }
  size_t recorded() const { return recorder_.frames(); }

 private:
  std::unique_ptr<FrameSource> inner_;
  TumRecorder recorder_;
};

}  // namespace rgbdmap
