// robots.txt: cameras (with their readout) and camera mounts survive a restart; a file written before mounts
// existed (v1) reads with the default mount, one before readouts (v1, v2) with readout 0; malformed lines are
// refused. Each keyframe outcome is counted in its own field.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "common/temp_dir.hpp"
#include "rgbdmap/intake/robot_registry.hpp"

namespace rgbdmap {
namespace {

/// A directory of that name under the test temp dir, unique per process, removed if present and at exit.
std::string freshDir(const std::string& name) { return testing::processDir("rgbdmap_intake_", name); }

void writeText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(RobotRegistryFile, MountsSurviveARestartAndOldFilesReadWithTheDefault) {
  const std::string dir = freshDir("registry");
  std::filesystem::create_directories(dir);
  RobotRegistry a;
  const SE3 mount = CameraMount{{0.1, 0.0, 0.4}, {0.0, 15.0, 0.0}}.T_base_camera();
  ASSERT_TRUE(a.hello("robot0", 1, CameraIntrinsics{}, mount));
  CameraIntrinsics global_shutter;
  global_shutter.readout_s = 0.0;
  ASSERT_TRUE(a.hello("robot1", 1, global_shutter));
  EXPECT_FALSE(*a.hello("robot0", 2, CameraIntrinsics{}, mount)) << "nothing new to persist";
  ASSERT_TRUE(a.save(dir));
  RobotRegistry b;
  ASSERT_TRUE(b.load(dir));
  EXPECT_TRUE(b.mount("robot0").isApprox(mount, 1e-12));
  EXPECT_TRUE(b.mount("robot1").isApprox(defaultT_base_camera(), 1e-12));
  EXPECT_TRUE(b.mount("never_seen").isApprox(defaultT_base_camera(), 1e-12));
  EXPECT_EQ(b.index("robot1"), 1);
  ASSERT_TRUE(b.camera("robot0") && b.camera("robot1"));
  EXPECT_EQ(b.camera("robot0")->readout_s, CameraIntrinsics{}.readout_s);
  EXPECT_EQ(b.camera("robot1")->readout_s, 0.0);
  EXPECT_GT(CameraIntrinsics{}.readout_s, 0.0);
  EXPECT_TRUE(*b.hello("robot1", 3, CameraIntrinsics{}, mount)) << "a new mount is persisted";

  writeText(dir + "/robots.txt",
            "# rgbdmap robots v1: id index fx fy cx cy width height k1 k2 p1 p2 k3 depth_scale\n"
            "robot0 0 517.3 516.5 318.6 255.3 640 480 0.2624 -0.9531 -0.0054 0.0026 1.1633 5000\n");
  RobotRegistry old;
  ASSERT_TRUE(old.load(dir));
  EXPECT_TRUE(old.mount("robot0").isApprox(defaultT_base_camera(), 1e-12));
  ASSERT_TRUE(old.camera("robot0"));
  EXPECT_EQ(old.camera("robot0")->depth_scale, 5000.0);
  EXPECT_EQ(old.camera("robot0")->readout_s, 0.0) << "v1: the model of the server that mapped it";

  writeText(dir + "/robots.txt",
            "robot0 0 517.3 516.5 318.6 255.3 640 480 0 0 0 0 0 5000 0.1 0 0.4 0 0 0 1\n");
  RobotRegistry v2;
  ASSERT_TRUE(v2.load(dir));
  EXPECT_TRUE(v2.mount("robot0").translation().isApprox(Vec3(0.1, 0.0, 0.4), 1e-12));
  EXPECT_EQ(v2.camera("robot0")->readout_s, 0.0) << "v2: no readout";
  writeText(dir + "/robots.txt",
            "robot0 0 517.3 516.5 318.6 255.3 640 480 0 0 0 0 0 5000 0 0 0 0 0 0 1 0.02 7\n");
  EXPECT_FALSE(RobotRegistry().load(dir)) << "a number after the readout";
  writeText(dir + "/robots.txt",
            "robot0 0 517.3 516.5 318.6 255.3 640 480 0 0 0 0 0 5000 0 0 0 0 0 0 1 -1\n");
  EXPECT_FALSE(RobotRegistry().load(dir)) << "a negative readout";
  writeText(dir + "/robots.txt", "robot0 0 517.3 516.5 318.6 255.3 640 480 0 0 0 0 0 5000 0 0 0 0 0 0 1 x\n");
  EXPECT_FALSE(RobotRegistry().load(dir)) << "a word after the mount";

  writeText(dir + "/robots.txt", "robot0 0 517.3 516.5 318.6 255.3 640 480 0 0 0 0 0 5000 0.1 0 0.4\n");
  EXPECT_FALSE(RobotRegistry().load(dir)) << "a partial mount";
  writeText(dir + "/robots.txt", "robot0 0 517.3 516.5 318.6 255.3 640 480 0 0 0 0 0 5000 0 0 0 0 0 0 2\n");
  EXPECT_FALSE(RobotRegistry().load(dir)) << "not a unit quaternion";
}

TEST(RobotRegistry, EachKeyframeOutcomeIsCountedInItsOwnField) {
  using Outcome = RobotRegistry::KeyframeOutcome;
  RobotRegistry registry;
  ASSERT_TRUE(registry.hello("robot0", 1, CameraIntrinsics{}));
  const Outcome outcomes[] = {Outcome::kPlaced,          Outcome::kDuplicate,
                              Outcome::kRefused,         Outcome::kRefusedBeforeDecode,
                              Outcome::kOutOfOrder,      Outcome::kChainSplit,
                              Outcome::kWaitingForHello, Outcome::kQueueFull,
                              Outcome::kDuplicateQueued, Outcome::kThrottled};
  for (size_t k = 0; k < std::size(outcomes); ++k)  // the k-th outcome k + 1 times
    for (size_t i = 0; i <= k; ++i) registry.recordKeyframe("robot0", outcomes[k]);
  registry.countLoop("robot0");
  registry.recordKeyframe("robot1", Outcome::kThrottled);  // no Hello: counted, not listed
  const std::vector<ServerRobotStats> stats = registry.stats();
  ASSERT_EQ(stats.size(), 1u);
  const ServerRobotStats& r = stats[0];
  EXPECT_EQ(r.keyframes, 1);
  EXPECT_EQ(r.duplicates, 2u);
  EXPECT_EQ(r.keyframes_refused, 3u);
  EXPECT_EQ(r.refused_before_decode, 4u);
  EXPECT_EQ(r.out_of_order, 5u);
  EXPECT_EQ(r.chain_splits, 6u);
  EXPECT_EQ(r.waiting_for_hello, 7u);
  EXPECT_EQ(r.queue_full, 8u);
  EXPECT_EQ(r.duplicates_queued, 9u);
  EXPECT_EQ(r.throttled, 10u);
  EXPECT_EQ(r.loops, 1);
}

}  // namespace
}  // namespace rgbdmap
