// runRobot on a short synthetic sequence against the fake server; the client configuration file and keys.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "common/temp_dir.hpp"
#include "config_file_check.hpp"
#include "fake_map_server.hpp"
#include "link_test_util.hpp"
#include "rgbdmap/client/odometry_config_io.hpp"
#include "rgbdmap/dataset/trajectory_smoothing.hpp"
#include "rgbdmap/link/robot_client_config.hpp"
#include "rgbdmap/link/robot_runner.hpp"
#include "rgbdmap/synth/synth.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

using testing::maxPoseDifference;
using testing::testPose;

/// A fake server that answers robot0 with one T_map_odom, and robot0's link to it, started, over memq.
struct ServerAndLink {
  ServerAndLink(const SE3& T_map_odom, const CameraIntrinsics& camera)
      : transport(testing::makeMemq()),
        server(*transport, serverOptions(T_map_odom)),
        options(linkOptions(camera)),
        link(*transport, options) {
    server.start();
    started = static_cast<bool>(link.start());
  }
  static testing::FakeServerOptions serverOptions(const SE3& T_map_odom) {
    testing::FakeServerOptions so;
    so.verify_key = so.sign_key = testing::linkKey(1);
    so.T_map_odom = {{0, T_map_odom}};
    return so;
  }
  static RobotLinkOptions linkOptions(const CameraIntrinsics& camera) {
    RobotLinkOptions lo = testing::linkOptions("robot0", testing::linkKey(1));
    lo.camera = camera;
    return lo;
  }
  std::unique_ptr<transport::Transport> transport;
  testing::FakeMapServer server;
  RobotLinkOptions options;
  RobotLink link;
  bool started = false;
};

class RobotRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new rgbdmap::testing::TempDir();
    config_.scene = "sweep";
    config_.frames = 20;
    config_.camera = {262.5, 262.5, 159.5, 119.5, 320, 240, {0, 0, 0, 0, 0}, 5000.0, 0.0};  // quarter size: fast
    ASSERT_TRUE(writeSyntheticSequence(config_, dir_->dir()));
  }
  static void TearDownTestSuite() { delete dir_; }
  TumDataset dataset(const std::string& dir = dir_->dir()) const {
    DatasetOptions o;
    o.depth_scale = config_.camera.depth_scale;
    o.expected_width = config_.camera.width;
    o.expected_height = config_.camera.height;
    auto d = TumDataset::open(dir, o);
    EXPECT_TRUE(d) << d.error();
    return std::move(d).value();
  }
  static rgbdmap::testing::TempDir* dir_;
  static SynthConfig config_;
};
rgbdmap::testing::TempDir* RobotRun::dir_ = nullptr;
SynthConfig RobotRun::config_;

RGBDMAP_TEST_TIER("RobotRun.*", "e2e");
RGBDMAP_TEST_TIER("RobotRun.FinalMapIsTheServersTransformTimesOdometry", "e2e sanitize");
TEST_F(RobotRun, FinalMapIsTheServersTransformTimesOdometry) {
  const SE3 T_map_odom = testPose(3);
  ServerAndLink sl(T_map_odom, config_.camera);
  ASSERT_TRUE(sl.started);
  testing::FakeMapServer& server = sl.server;
  const RobotLinkOptions& lo = sl.options;
  RobotRunOptions ro;
  ro.realtime = false;
  ro.final_wait_s = 10.0;
  int progress_calls = 0;
  ro.progress = [&](int done, int total) { progress_calls += done <= total; };
  const RobotRunResult r = runRobot(dataset(), config_.camera, OdometryConfig{}, sl.link, ro);

  ASSERT_EQ(r.frames, 20);
  EXPECT_EQ(progress_calls, 20);
  EXPECT_EQ(r.unreadable_frames, 0);
  EXPECT_EQ(r.segments, 1);
  ASSERT_GE(r.keyframes, 2);
  EXPECT_EQ(r.keyframes_not_sent, 0);
  EXPECT_TRUE(r.all_acked);
  EXPECT_TRUE(r.final_correction_received);
  EXPECT_FALSE(r.interrupted);
  EXPECT_EQ(r.link.keyframes_acked, static_cast<uint64_t>(r.keyframes));
  ASSERT_EQ(r.final_map.size(), 20u);
  ASSERT_EQ(r.live.size(), 20u);
  ASSERT_EQ(r.odometry.size(), 20u);
  // The final trajectory: the odometry re-anchored by the correction, then smoothed (OdometryConfig's
  // default trajectory_smoothing_s; a rigid transform commutes with the smoothing).
  EXPECT_EQ(r.trajectory_smoothing_s, OdometryConfig{}.trajectory_smoothing_s);
  const Trajectory smoothed_odometry = smoothTrajectory(r.odometry, {}, r.trajectory_smoothing_s);
  for (size_t i = 0; i < static_cast<size_t>(r.frames); ++i) {
    const SE3 expected = T_map_odom * r.odometry[i].T_world_cam;
    EXPECT_LT(maxPoseDifference(r.final_map[i].T_world_cam, T_map_odom * smoothed_odometry[i].T_world_cam),
              1e-9)
        << "frame " << i;
    EXPECT_EQ(r.final_map[i].timestamp, r.odometry[i].timestamp);
    // Live poses use whatever correction had arrived: none yet (the camera mount), or this one.
    EXPECT_LT(
        std::min(maxPoseDifference(r.live[i].T_world_cam, expected),
                 maxPoseDifference(r.live[i].T_world_cam, lo.T_base_camera * r.odometry[i].T_world_cam)),
        1e-9)
        << "frame " << i;
  }
  std::lock_guard<std::mutex> lock(server.state().mutex);
  ASSERT_EQ(server.state().stored.size(), r.keyframes_final.size());
  size_t k = 0;
  for (const auto& [id, kf] : server.state().stored) {
    EXPECT_LT(maxPoseDifference(r.keyframes_final[k++].T_world_cam, T_map_odom * kf.T_odom_cam), 1e-9) << id;
    EXPECT_EQ(kf.robot_id, "robot0");
  }
  // The odometry itself is good on this easy sweep: the link does not disturb it.
  const TumDataset data = dataset();
  ASSERT_TRUE(data.groundTruth().has_value());
  const Trajectory& gt = *data.groundTruth();
  const SE3 T_gt0 = gt.front().T_world_cam;
  const SE3 moved = T_gt0.inverse() * gt[19].T_world_cam;
  EXPECT_LT((r.odometry[19].T_world_cam.translation() - moved.translation()).norm(), 0.03);
}

TEST_F(RobotRun, LostFramesAreBridgedBetweenTheTrackedFramesAroundThem) {
  // Frames 8-10 blanked to one grey: no corner, so the odometry loses them and holds its prediction; frame 11
  // tracks again in the same segment.
  rgbdmap::testing::TempDir blank_dir;
  ASSERT_TRUE(writeSyntheticSequence(config_, blank_dir.dir()));
  std::ifstream list(blank_dir.path("rgb.txt"));
  std::string line;
  int index = 0;
  while (std::getline(list, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (index >= 8 && index <= 10) {
      const std::string file = line.substr(line.find(' ') + 1);
      ASSERT_TRUE(cv::imwrite(blank_dir.path(file), cv::Mat(config_.camera.height, config_.camera.width,
                                                            CV_8UC3, cv::Scalar::all(128))));
    }
    ++index;
  }
  const SE3 T_map_odom = testPose(5);
  ServerAndLink sl(T_map_odom, config_.camera);
  ASSERT_TRUE(sl.started);
  RobotRunOptions ro;
  ro.realtime = false;
  ro.final_wait_s = 10.0;
  OdometryConfig unsmoothed;
  unsmoothed.trajectory_smoothing_s = 0.0;
  const RobotRunResult r = runRobot(dataset(blank_dir.dir()), config_.camera, unsmoothed, sl.link, ro);
  ASSERT_EQ(r.frames, 20);
  ASSERT_TRUE(r.final_correction_received);
  EXPECT_EQ(r.segments, 1);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(r.frame_records[i].tracked, i < 8 || i > 10) << "frame " << i;
  const double span = r.odometry[11].timestamp - r.odometry[7].timestamp;
  for (size_t i = 0; i < 20; ++i) {
    const SE3 odometry_in_map = T_map_odom * r.odometry[i].T_world_cam;
    const SE3 expected = i < 8 || i > 10
                             ? odometry_in_map
                             : se3::interpolate(T_map_odom * r.odometry[7].T_world_cam,
                                                T_map_odom * r.odometry[11].T_world_cam,
                                                (r.odometry[i].timestamp - r.odometry[7].timestamp) / span);
    EXPECT_LT(maxPoseDifference(r.final_map[i].T_world_cam, expected), 1e-9) << "frame " << i;
  }
  // The held prediction is not what the final trajectory reports.
  EXPECT_GT(maxPoseDifference(r.final_map[10].T_world_cam, T_map_odom * r.odometry[10].T_world_cam), 1e-6);
}

TEST_F(RobotRun, RealtimePacingFrameRangeAndStop) {
  auto transport = testing::makeMemq();
  RobotLinkOptions lo = testing::linkOptions("robot1", {});
  lo.camera = config_.camera;
  RobotLink link(*transport, lo);  // no server: nothing is acknowledged
  ASSERT_TRUE(link.start());
  RobotRunOptions ro;
  ro.first_frame = 5;
  ro.end_frame = 11;
  ro.final_wait_s = 0.0;
  OdometryConfig unsmoothed;
  unsmoothed.trajectory_smoothing_s = 0.0;
  const RobotRunResult r = runRobot(dataset(), config_.camera, unsmoothed, link, ro);
  EXPECT_EQ(r.frames, 6);
  EXPECT_NEAR(r.odometry.front().timestamp, config_.colorTimestamp(5), 1e-5);
  EXPECT_GE(r.wall_s, 5.0 / config_.fps) << "frames are paced by their timestamps";
  EXPECT_FALSE(r.all_acked);
  EXPECT_FALSE(r.final_correction_received);
  for (size_t i = 0; i < r.final_map.size(); ++i)  // uncorrected: the odometry frame on the camera mount
    EXPECT_LT(maxPoseDifference(r.final_map[i].T_world_cam, lo.T_base_camera * r.odometry[i].T_world_cam),
              1e-12);

  StopRequest stop;
  stop.request();
  ro.stop = &stop;
  const RobotRunResult stopped = runRobot(dataset(), config_.camera, OdometryConfig{}, link, ro);
  EXPECT_TRUE(stopped.interrupted);
  EXPECT_EQ(stopped.frames, 0);
  ro.first_frame = 30;  // past the end: nothing to do, no crash
  ro.stop = nullptr;
  EXPECT_EQ(runRobot(dataset(), config_.camera, OdometryConfig{}, link, ro).frames, 0);
}

const std::string kClientExample = std::string(RGBDMAP_SOURCE_DIR) + "/deploy/config/client.yaml";

void readEverything(ConfigReader& reader, RobotClientConfig* client, CameraIntrinsics* camera,
                    OdometryConfig* odometry) {
  readRobotClientConfig(reader, client);
  readCameraConfig(reader, "camera.", camera);
  readOdometryConfig(reader, odometry);
  DatasetOptions dataset;
  readDatasetConfig(reader, &dataset);
}

TEST(ClientConfig, ExampleLoadsWithoutErrorsAndStatesTheDefaults) {
  auto from_file = ConfigReader::fromFile(kClientExample);
  ASSERT_TRUE(from_file) << from_file.error();
  ConfigReader defaults;
  RobotClientConfig c1, c2;
  CameraIntrinsics k1, k2;
  OdometryConfig o1, o2;
  readEverything(*from_file, &c1, &k1, &o1);
  readEverything(defaults, &c2, &k2, &o2);
  for (const auto& e : from_file->errors()) ADD_FAILURE() << e;
  EXPECT_EQ(from_file->effectiveValues(), defaults.effectiveValues());
}

TEST(ClientConfig, ExampleIsTheTablesRendering) {
  const char* header =
      "rgbdmap-client configuration: every key of the robot program with its default value, [range] and\n"
      "meaning. Any key may be left out (the default applies); unknown keys and out-of-range values are\n"
      "reported together at start-up (exit 2). Used by `build/bin/rgbdmap-client --config FILE`. The "
      "odometry\n"
      "is configured exactly as for `rgbdmap odometry --config`: the camera:, dataset: and odometry: "
      "sections\n"
      "of deploy/config/odometry.yaml may be added to this file unchanged. Rendered from the config tables\n"
      "(robotClientConfigValues); tests/client/test_robot_run.cpp checks that this file is exactly their\n"
      "rendering.";
  testing::expectFileEqualsRendering(kClientExample, renderConfigYaml(header, robotClientConfigValues({})));
}

TEST(ClientConfig, BadValuesAreAllReported) {
  auto reader = ConfigReader::fromString(
      "robot: {id: r1}\nlink:\n  heartbeat_period_s: 0\n  codec: {color: png, jpeg_quality: 101}\n"
      "  reliable: {initial_backoff_ms: 500, max_backoff_ms: 100, min_backoff_ms: 600}\n  bogus: 1\n",
      "c.yaml");
  ASSERT_TRUE(reader);
  RobotClientConfig c;
  readRobotClientConfig(*reader, &c);
  const auto errors = reader->errors();
  EXPECT_EQ(errors.size(), 6u) << "heartbeat, colour, quality, backoff order (max, min), unknown key";
  EXPECT_EQ(c.robot_id, "r1");
  EXPECT_EQ(c.link.codec.color, ColorCodec::kJpeg) << "defaults kept on error";
}

TEST(ClientConfig, KeyFiles) {
  rgbdmap::testing::TempDir tmp;
  tmp.write("good.key", "# robot0\n" + std::string(32, 'a') + "\n  " + std::string(32, '0') + "\n");
  tmp.write("short.key", "abcd\n");
  tmp.write("nonhex.key", std::string(63, 'a') + "z\n");
  const auto key = readKeyFile("good.key", tmp.dir());
  ASSERT_TRUE(key) << key.error();
  EXPECT_EQ(key->size(), 32u);
  EXPECT_EQ((*key)[0], 0xaa);
  EXPECT_EQ((*key)[31], 0x00);
  EXPECT_FALSE(readKeyFile("short.key", tmp.dir()));
  EXPECT_FALSE(readKeyFile("nonhex.key", tmp.dir()));
  EXPECT_FALSE(readKeyFile("missing.key", tmp.dir()));
  EXPECT_TRUE(readKeyFile(tmp.path("good.key")));
}

}  // namespace
}  // namespace rgbdmap
