// Recorded keyframe streams (keyframe_stream.hpp) and their replay as another robot (keyframe_replay.hpp).
#include <gtest/gtest.h>

#include <random>

#include "common/temp_dir.hpp"
#include "fake_map_server.hpp"
#include "link_test_util.hpp"
#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/link/keyframe_replay.hpp"
#include "rgbdmap/link/keyframe_stream.hpp"

namespace rgbdmap {
namespace {

using testing::testPose;

/// Robot "robot0" sends `n` keyframes in one chain (ids 0, 2, 4, ...: gaps as a real odometry leaves them),
/// recorded through the link's keyframe tap; the recording's path.
std::string recordStream(const rgbdmap::testing::TempDir& dir, int n) {
  auto transport = testing::makeMemq();
  testing::FakeServerOptions so;
  so.verify_key = so.sign_key = testing::linkKey(1);
  testing::FakeMapServer server(*transport, so);
  server.start();
  RobotLinkOptions lo = testing::linkOptions("robot0", testing::linkKey(1));
  const std::string path = dir.path("robot0.rkf");
  KeyframeStreamWriter writer(path, makeHello(lo));
  lo.keyframe_tap = [&writer](const msg::Bytes& p) { writer.append(p); };
  RobotLink link(*transport, lo);
  EXPECT_TRUE(link.start());
  for (int i = 0; i < n; ++i) {
    const int id = 2 * i;
    EXPECT_TRUE(link.sendKeyframe(testing::smallKeyframe(id, 0, testPose(i), i > 0 ? id - 2 : -1),
                                  testing::smallFrame(i)));
  }
  EXPECT_TRUE(link.waitAllAcked(10.0));
  link.stop();
  EXPECT_EQ(writer.keyframes(), static_cast<size_t>(n));
  EXPECT_TRUE(writer.close());
  return path;
}

TEST(KeyframeStream, WhatTheLinkSentReadsBackAsSent) {
  rgbdmap::testing::TempDir dir;
  const std::string path = recordStream(dir, 5);
  Result<KeyframeStream> s = readKeyframeStream(path);
  ASSERT_TRUE(s) << s.error();
  EXPECT_EQ(s->hello.robot_id, "robot0");
  EXPECT_EQ(s->hello.camera.width, testing::linkOptions("robot0", {}).camera.width);
  ASSERT_EQ(s->keyframes.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    const msg::Keyframe& k = s->keyframes[static_cast<size_t>(i)];
    EXPECT_EQ(k.keyframe_id, 2 * i);
    EXPECT_EQ(k.previous_keyframe_id, i > 0 ? 2 * i - 2 : -1);
    EXPECT_LT(testing::maxPoseDifference(k.T_odom_cam, testPose(i)), 1e-9);
    EXPECT_FALSE(k.images.depth.empty());
  }
}

TEST(KeyframeStream, CorruptOrTruncatedStreamsAreRefusedWithTheRecord) {
  rgbdmap::testing::TempDir dir;
  Result<std::string> bytes = readTextFile(recordStream(dir, 3));
  ASSERT_TRUE(bytes);
  const std::string good = *bytes;
  ASSERT_TRUE(parseKeyframeStream(good));
  EXPECT_NE(parseKeyframeStream("").error().find("magic"), std::string::npos);
  EXPECT_NE(parseKeyframeStream("RGBDKFS1").error().find("no keyframe"), std::string::npos);
  EXPECT_NE(parseKeyframeStream(good.substr(0, good.size() - 1)).error().find("truncated"),
            std::string::npos);
  std::string huge = good;
  huge[8 + 3] = '\x7f';  // the Hello's size: ~2 GB
  EXPECT_NE(parseKeyframeStream(huge).error().find("too large"), std::string::npos);
  // A second Hello where a keyframe belongs.
  const size_t hello_bytes = 4 + (static_cast<uint8_t>(good[8]) | static_cast<uint8_t>(good[9]) << 8);
  EXPECT_NE(parseKeyframeStream(good + good.substr(8, hello_bytes)).error().find("not a keyframe"),
            std::string::npos);
  // Every truncation and a few thousand random byte changes: refused with a reason or read whole; never a
  // crash (the sanitizer tree runs this too). A stream that still reads holds only valid keyframes.
  for (size_t n = 0; n < good.size(); n += 97) EXPECT_FALSE(parseKeyframeStream(good.substr(0, n))) << n;
  std::mt19937 rng(7);
  int refused = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::string bad = good;
    for (int k = 0; k < 1 + trial % 4; ++k) bad[rng() % bad.size()] = static_cast<char>(rng());
    Result<KeyframeStream> r = parseKeyframeStream(bad);
    if (!r) {
      EXPECT_FALSE(r.error().empty());
      ++refused;
    } else {
      EXPECT_EQ(r->keyframes.size(), 3u);
    }
  }
  EXPECT_GT(refused, 100);
  EXPECT_FALSE(readKeyframeStream(dir.path("missing.rkf")));
}

TEST(KeyframeReplay, PassesRenumberIdsStartNewChainsAndEveryKeyframeIsAcknowledged) {
  rgbdmap::testing::TempDir dir;
  Result<KeyframeStream> stream = readKeyframeStream(recordStream(dir, 4));  // ids 0 2 4 6
  ASSERT_TRUE(stream) << stream.error();
  auto transport = testing::makeMemq();
  testing::FakeServerOptions so;
  so.robot_id = "replay1";
  so.verify_key = so.sign_key = testing::linkKey(2);
  testing::FakeMapServer server(*transport, so);
  server.start();
  RobotLinkOptions lo = testing::linkOptions("replay1", testing::linkKey(2));
  lo.camera = stream->hello.camera;
  RobotLink link(*transport, lo);
  ASSERT_TRUE(link.start());
  ReplayOptions ro;
  ro.rate_hz = 40.0;
  ro.duration_s = 0.25;  // 10 keyframes: 2 from the first pass (start 2), 4, 4
  ro.start = 2;
  ro.final_wait_s = 10.0;
  const ReplayResult r = replayKeyframes(*stream, link, ro);
  link.stop();
  ASSERT_EQ(r.keyframes.size(), 10u);
  EXPECT_EQ(r.passes, 3u);
  EXPECT_EQ(r.acked(), 10u);
  EXPECT_EQ(r.send_failures, 0u);
  EXPECT_FALSE(r.stopped);
  EXPECT_GE(r.keyframes.back().sent_s, 9 / 40.0 - 1e-3) << "paced at 40 Hz";
  EXPECT_GE(r.ackQuantileMs(1.0), r.ackQuantileMs(0.5));
  const std::vector<int> ids = {4, 6, 7, 9, 11, 13, 14, 16, 18, 20};  // pass p adds 7 p
  const std::vector<int> previous = {-1, 4, -1, 7, 9, 11, -1, 14, 16, 18};
  const std::vector<int> segments = {0, 0, 1, 1, 1, 1, 2, 2, 2, 2};
  std::lock_guard<std::mutex> lock(server.state().mutex);
  ASSERT_EQ(server.state().stored.size(), 10u);
  for (size_t i = 0; i < ids.size(); ++i) {
    EXPECT_EQ(r.keyframes[i].id, ids[i]);
    const msg::Keyframe& k = server.state().stored.at(ids[i]);
    EXPECT_EQ(k.robot_id, "replay1");
    EXPECT_EQ(k.previous_keyframe_id, previous[i]) << ids[i];
    EXPECT_EQ(k.segment_id, segments[i]) << ids[i];
    if (i > 0) {
      EXPECT_GT(k.timestamp, server.state().stored.at(ids[i - 1]).timestamp) << ids[i];
    }
  }
}

}  // namespace
}  // namespace rgbdmap
