#pragma once
// Shared by the frame-source tests: one small synthetic sweep in TUM layout (quarter size: fast), written
// once per test binary, and helpers to drain a source.
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/temp_dir.hpp"
#include "rgbdmap/source/frame_source.hpp"
#include "rgbdmap/synth/synth.hpp"

namespace rgbdmap::testing {

inline SynthConfig sourceTestConfig(int frames = 20) {
  SynthConfig c;
  c.scene = "sweep";
  c.frames = frames;
  c.seed = 3;
  c.camera = {262.5, 262.5, 159.5, 119.5, 320, 240, {0, 0, 0, 0, 0}, 5000.0, 0.0};
  return c;
}

inline SourceOptions sourceOptionsFor(const CameraIntrinsics& camera) {
  SourceOptions o;
  o.depth_scale = camera.depth_scale;
  o.expected_width = camera.width;
  o.expected_height = camera.height;
  return o;
}

/// Every frame until kEnd; a kFailed or kUnreadable read fails the test.
inline std::vector<RgbdFrame> drainSource(FrameSource& source) {
  std::vector<RgbdFrame> frames;
  for (;;) {
    FrameRead r = source.next();
    if (r.kind == FrameRead::Kind::kEnd) return frames;
    EXPECT_EQ(r.kind, FrameRead::Kind::kFrame) << r.error;
    if (r.kind != FrameRead::Kind::kFrame) return frames;
    frames.push_back(std::move(r.frame));
  }
}

inline std::unique_ptr<FrameSource> openOrFail(const std::string& url_text, const SourceOptions& options) {
  auto url = SourceUrl::parse(url_text);
  EXPECT_TRUE(url) << url.error();
  if (!url) return nullptr;
  auto source = openFrameSource(*url, options);
  EXPECT_TRUE(source) << source.error();
  return source ? std::move(*source) : nullptr;
}

/// The shared synthetic sweep's folder (written on first use, removed at exit).
inline const std::string& sourceTestFolder() {
  static TempDir dir;
  static const std::string path = [] {
    const Status s = writeSyntheticSequence(sourceTestConfig(), dir.dir());
    EXPECT_TRUE(s) << s.error();
    return dir.dir();
  }();
  return path;
}

/// The shared sequence's frames read from its folder (what every recording of it must give back).
inline std::vector<RgbdFrame> sourceTestFrames() {
  auto source = openOrFail("tum:" + sourceTestFolder(), sourceOptionsFor(sourceTestConfig().camera));
  return source ? drainSource(*source) : std::vector<RgbdFrame>{};
}

/// The reason openFrameSource gives for `url` (empty when it opens).
inline std::string openSourceError(const std::string& url) {
  auto parsed = SourceUrl::parse(url);
  if (!parsed) return parsed.error();
  auto source = openFrameSource(*parsed, {});
  return source ? std::string() : source.error();
}

}  // namespace rgbdmap::testing
