// Live behaviour: a synthetic sequence paced at 30 Hz as a live camera, read through
// LatestFrameSource by an odometry slowed to ~15 Hz: frames are never delivered before the camera made them,
// the newest wins, every dropped frame is counted, at most one frame waits, and the trajectory of the frames
// that were tracked stays within bound. A reader that stalls does not make memory grow.
#include <chrono>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>
#include <unistd.h>

#include "rgbdmap/client/odometry.hpp"
#include "rgbdmap/dataset/evaluation.hpp"
#include "rgbdmap/source/live_source.hpp"
#include "source/source_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using LiveClock = std::chrono::steady_clock;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kLiveSanitized = true;  // slower odometry; freed frames stay in ASan's quarantine
#else
constexpr bool kLiveSanitized = false;
#endif

/// Frames rendered in memory, handed out in order (a recording; makePacedSource makes it live).
class RenderedSource : public FrameSource {
 public:
  RenderedSource(std::vector<RgbdFrame> frames, CameraIntrinsics camera)
      : frames_(std::move(frames)), camera_(camera) {}
  FrameRead next() override {
    if (next_ >= frames_.size()) return FrameRead::end();
    const size_t i = next_++;
    return FrameRead::ok(i, frames_[i]);
  }
  bool live() const override { return false; }
  std::optional<CameraIntrinsics> camera() const override { return camera_; }
  std::string describe() const override { return "rendered"; }
  size_t sizeHint() const override { return frames_.size(); }

 private:
  std::vector<RgbdFrame> frames_;
  CameraIntrinsics camera_;
  size_t next_ = 0;
};

/// A camera that makes a new full-size frame every 1/30 s until `count` (fresh memory each time).
class GeneratedCamera : public FrameSource {
 public:
  explicit GeneratedCamera(size_t count) : count_(count), start_(LiveClock::now()) {}
  FrameRead next() override {
    if (made_ >= count_) return FrameRead::end();
    std::this_thread::sleep_until(start_ + std::chrono::microseconds(33333 * made_));
    RgbdFrame f;
    f.timestamp = static_cast<double>(made_) / 30.0;
    f.color = cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(static_cast<double>(made_ % 255)));
    f.depth = cv::Mat(480, 640, CV_16UC1, cv::Scalar::all(5000));
    return FrameRead::ok(made_++, std::move(f));
  }
  bool live() const override { return true; }
  std::optional<CameraIntrinsics> camera() const override { return std::nullopt; }
  std::string describe() const override { return "generated"; }

 private:
  size_t count_, made_ = 0;
  LiveClock::time_point start_;
};

double residentMb() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1e6;
}

RGBDMAP_TEST_TIER("LiveRate.*", "e2e");
TEST(LiveRate, SlowOdometryDropsFramesCountsThemAndStaysOnTrack) {
  const SynthConfig config = testing::sourceTestConfig(90);  // 3 s at 30 Hz
  auto scene = SyntheticScene::build(config);
  ASSERT_TRUE(scene) << scene.error();
  std::vector<RgbdFrame> frames;
  for (int i = 0; i < config.frames; ++i) frames.push_back(scene->renderFrame(i));
  LatestFrameSource live(makePacedSource(std::make_unique<RenderedSource>(std::move(frames), config.camera)));
  VisualOdometry vo(config.camera, {});
  Trajectory estimate;
  const LiveClock::time_point start = LiveClock::now();
  double first_stamp = -1, earliest_s = 1e9;
  for (FrameRead r = live.next(); r.kind == FrameRead::Kind::kFrame; r = live.next()) {
    const double wall_s = std::chrono::duration<double>(LiveClock::now() - start).count();
    if (first_stamp < 0) first_stamp = r.frame.timestamp;
    earliest_s = std::min(earliest_s, wall_s - (r.frame.timestamp - first_stamp));  // < 0: read too early
    estimate.push_back({r.frame.timestamp, vo.track(r.frame).T_odom_cam});
    std::this_thread::sleep_for(std::chrono::milliseconds(55));  // odometry at ~15 Hz
  }
  const LatestFrameStats s = live.stats();
  EXPECT_EQ(s.produced, 90u);
  EXPECT_EQ(s.delivered + s.dropped, s.produced);
  EXPECT_EQ(s.delivered, estimate.size());
  EXPECT_GE(s.dropped, 25u);                         // ~half of 90 at 15 of 30 Hz
  EXPECT_LE(s.dropped, kLiveSanitized ? 80u : 65u);  // under ASan the odometry itself is slower
  EXPECT_EQ(live.droppedFrames(), s.dropped);
  EXPECT_EQ(s.max_pending, 1u);   // bounded: one frame waits at most
  EXPECT_GT(earliest_s, -0.005);  // never delivered before the camera made it
  auto ate = computeAte(scene->trajectory(), estimate);
  ASSERT_TRUE(ate) << ate.error();
  EXPECT_LT(ate->rmse, 0.02) << "ATE over the " << estimate.size() << " tracked frames";
  std::printf("live 30 Hz, odometry ~15 Hz: delivered %zu, dropped %zu, ATE %.4f m\n", s.delivered, s.dropped,
              ate->rmse);
}

TEST(LiveRate, MemoryStaysFlatWhileTheReaderStalls) {
  if (kLiveSanitized)
    GTEST_SKIP() << "AddressSanitizer keeps freed frames in its quarantine: RSS says nothing";
  const double before_mb = residentMb();
  LatestFrameSource live(std::make_unique<GeneratedCamera>(75));  // 2.5 s, 1.5 MB per frame
  size_t read = 0;
  double peak_mb = before_mb;
  for (FrameRead r = live.next(); r.kind == FrameRead::Kind::kFrame; r = live.next()) {
    ++read;
    std::this_thread::sleep_for(std::chrono::milliseconds(400));  // a reader 12x slower than the camera
    peak_mb = std::max(peak_mb, residentMb());
  }
  const LatestFrameStats s = live.stats();
  EXPECT_EQ(s.produced, 75u);
  EXPECT_EQ(s.delivered, read);
  EXPECT_GE(s.dropped, 60u);
  EXPECT_EQ(s.max_pending, 1u);
  // An unbounded queue would hold ~65 frames (~100 MB) here; newest-wins holds one or two (~3 MB).
  EXPECT_LT(peak_mb - before_mb, 20.0) << "resident memory grew from " << before_mb << " to " << peak_mb;
  std::printf("stalled reader: read %zu of %zu, dropped %zu, resident +%.1f MB\n", read, s.produced,
              s.dropped, peak_mb - before_mb);
}

RGBDMAP_TEST_TIER("LiveRate.CloseEndsABlockedRead", "e2e sanitize");
TEST(LiveRate, CloseEndsABlockedRead) {
  LatestFrameSource live(std::make_unique<GeneratedCamera>(1000000));
  ASSERT_EQ(live.next().kind, FrameRead::Kind::kFrame);
  std::thread closer([&live] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    live.close();
  });
  for (FrameRead r = live.next(); r.kind == FrameRead::Kind::kFrame; r = live.next()) {
  }
  closer.join();
  SUCCEED();  // the destructor joins the reader thread: the test ends rather than waiting for 1e6 frames
}

}  // namespace
}  // namespace rgbdmap
