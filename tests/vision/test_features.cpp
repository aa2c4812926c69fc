// OrbExtractor: a keypoint's depth is the depth at its pixel, and none on a depth discontinuity.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "rgbdmap/vision/features.hpp"
#include "test_cameras.hpp"

namespace rgbdmap {
namespace {

constexpr int kSquare = 16;
constexpr int kStepColumn = 20 * kSquare;  ///< depth steps from 1 m to 2 m here, on a column of corners

/// A checkerboard (corners every 16 px) over a depth image split in two at kStepColumn, with a hole (no
/// measurement, as a Kinect's shadow) in rows [hole_top, hole_top + 64) of the left half.
RgbdFrame steppedFrame(int hole_top) {
  RgbdFrame f;
  f.color = cv::Mat(480, 640, CV_8UC1);
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x) f.color.at<uint8_t>(y, x) = ((x / kSquare + y / kSquare) % 2) ? 200 : 40;
  cv::GaussianBlur(f.color, f.color, cv::Size(3, 3), 0.7);
  f.depth = cv::Mat(480, 640, CV_16UC1);
  f.depth_scale = 5000.0;
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x) {
      // The left plane tilts a little: 1 m at the left edge, 1 m + 1 mm per 10 px towards the step.
      const double z = x < kStepColumn ? 1.0 + 0.0001 * x : 2.0;
      f.depth.at<uint16_t>(y, x) = static_cast<uint16_t>(std::lround(z * f.depth_scale));
    }
  f.depth(cv::Rect(64, hole_top, 128, 64)).setTo(0);
  return f;
}

struct Counts {
  int near_step = 0, near_step_with_depth = 0, far = 0, far_with_depth = 0, by_hole = 0,
      by_hole_with_depth = 0;
};

Counts classify(const FrameFeatures& f, const RgbdFrame& frame, int hole_top) {
  Counts c;
  for (size_t i = 0; i < f.size(); ++i) {
    const cv::Point2f p = f.keypoints[i].pt;
    const int x = static_cast<int>(std::lround(p.x)), y = static_cast<int>(std::lround(p.y));
    if (frame.depthMetres(x, y) == 0.0) continue;  // inside the hole
    const bool has = f.hasDepth(i);
    if (has) {
      EXPECT_NEAR(f.depth_m[i], frame.depthMetres(x, y), 1e-9) << "the depth at the keypoint's pixel";
    }
    if (std::abs(x - kStepColumn) <= 2) {
      ++c.near_step;
      c.near_step_with_depth += has;
    } else if (x >= 64 && x < 192 && (std::abs(y - hole_top) <= 2 || std::abs(y - (hole_top + 63)) <= 2)) {
      ++c.by_hole;
      c.by_hole_with_depth += has;
    } else if (std::abs(x - kStepColumn) > 8) {
      ++c.far;
      c.far_with_depth += has;
    }
  }
  return c;
}

TEST(OrbExtractor, AKeypointOnADepthStepHasNoDepthButOneBesideAHoleOrOnASlopeKeepsIt) {
  constexpr int kHoleTop = 8 * kSquare;
  const RgbdFrame frame = steppedFrame(kHoleTop);
  const PinholeCamera camera(testing::idealPinhole());
  OrbConfig config;
  config.n_features = 2000;
  const Counts on = classify(OrbExtractor(config).extract(frame, camera), frame, kHoleTop);
  ASSERT_GE(on.near_step, 8) << "the checkerboard has corners on the step column";
  ASSERT_GE(on.far, 100);
  ASSERT_GE(on.by_hole, 4);
  EXPECT_EQ(on.near_step_with_depth, 0) << "depth within 3 px spans 1 m to 2 m";
  EXPECT_EQ(on.far_with_depth, on.far) << "a slope of 0.7 mm over 7 px stays under 3 % of 1 m";
  EXPECT_EQ(on.by_hole_with_depth, on.by_hole) << "a missing measurement is not a discontinuity";

  config.depth_edge_radius_px = 0;
  const Counts off = classify(OrbExtractor(config).extract(frame, camera), frame, kHoleTop);
  EXPECT_EQ(off.near_step_with_depth, off.near_step) << "radius 0 turns the test off";
  EXPECT_GE(off.near_step, 8);

  config.depth_edge_radius_px = 3;
  config.depth_edge_max_spread = 1.5;  // the 1 m step is 100 % of 1 m: below the spread allowed
  const Counts loose = classify(OrbExtractor(config).extract(frame, camera), frame, kHoleTop);
  EXPECT_EQ(loose.near_step_with_depth, loose.near_step);
}

}  // namespace
}  // namespace rgbdmap
