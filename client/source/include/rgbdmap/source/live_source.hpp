#pragma once
// Wrappers that give every source the same live behaviour:
// - makeLatestFrameSource: a thread reads the live source as fast as it produces; the reader gets the newest
//   frame, and a frame replaced before anyone read it is dropped and counted. One frame waits at most (no
//   queue grows when the odometry falls behind), and the sensor is never read faster than it produces.
// - makePacedSource: a recording replayed as a live camera, each frame released at its timestamp relative to
//   the first (`tum:DIR?live`; the live-rate tests).
// - makeRangeSource: frames [first, end) of any source.
#include <cstddef>
#include <memory>

#include "rgbdmap/source/frame_source.hpp"

namespace rgbdmap {

/// Counters of a LatestFrameSource.
struct LatestFrameStats {
  size_t produced = 0;     ///< frames (and unreadable ones) the inner source yielded
  size_t delivered = 0;    ///< returned by next()
  size_t dropped = 0;      ///< replaced by a newer one before next() took them
  size_t max_pending = 0;  ///< most frames ever waiting at once (1 by construction)
};

class LatestFrameSource : public FrameSource {
 public:
  /// Starts reading `live` on a thread at once.
  explicit LatestFrameSource(std::unique_ptr<FrameSource> live);
  ~LatestFrameSource() override;
  LatestFrameSource(const LatestFrameSource&) = delete;
  LatestFrameSource& operator=(const LatestFrameSource&) = delete;

  FrameRead next() override;
  bool live() const override { return true; }
  std::optional<CameraIntrinsics> camera() const override;
  std::string describe() const override;
  size_t droppedFrames() const override { return stats().dropped; }
  void close() override;
  LatestFrameStats stats() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

std::unique_ptr<FrameSource> makeLatestFrameSource(std::unique_ptr<FrameSource> live);
std::unique_ptr<FrameSource> makePacedSource(std::unique_ptr<FrameSource> recording);
std::unique_ptr<FrameSource> makeRangeSource(std::unique_ptr<FrameSource> source, size_t first,
                                             long long end);

}  // namespace rgbdmap
