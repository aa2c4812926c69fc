// The ROS 2 bridge's pure parts: which robots share a map (from the loop edges each robot's map holds), the
// PointCloud2 bytes, ROS name tokens from robot ids.
#include <gtest/gtest.h>

#include <cstring>

#include "rgbdmap/common/camera_mount.hpp"
#include "rgbdmap/ros2/dds.hpp"
#include "rgbdmap/ros2_bridge/bridge.hpp"

namespace rgbdmap::ros2 {
namespace {

msg::MapLoopEdge edge(const std::string& from, const std::string& to) {
  msg::MapLoopEdge e;
  e.robot_from = from;
  e.robot_to = to;
  e.inter_robot = from != to;
  return e;
}

using Groups = std::vector<std::vector<std::string>>;

TEST(MapGroups, RobotsWithoutSharedLoopsAreMapsOfTheirOwn) {
  EXPECT_EQ(mapGroups({"a", "b", "c"}, {{edge("a", "a")}, {}, {edge("c", "c")}}),
            (Groups{{"a"}, {"b"}, {"c"}}));
}

TEST(MapGroups, AnEdgeBetweenRobotsJoinsTheirMapsAndTheLargestComesFirst) {
  // c's map holds an edge to b: b and c share a map, which has the most robots and comes first.
  EXPECT_EQ(mapGroups({"a", "b", "c"}, {{}, {}, {edge("c", "b")}}), (Groups{{"b", "c"}, {"a"}}));
  // Chained through d: a-b in a's map, b-d in d's map.
  EXPECT_EQ(mapGroups({"a", "b", "c", "d"}, {{edge("a", "b")}, {}, {}, {edge("b", "d")}}),
            (Groups{{"a", "b", "d"}, {"c"}}));
  // A tie goes to the robot listed first.
  EXPECT_EQ(mapGroups({"a", "b", "c", "d"}, {{edge("a", "b")}, {}, {edge("c", "d")}, {}}),
            (Groups{{"a", "b"}, {"c", "d"}}));
}

TEST(MapGroups, EdgesNamingRobotsNotServedAreIgnored) {
  EXPECT_EQ(mapGroups({"a", "b"}, {{edge("a", "ghost")}, {edge("", "b")}}), (Groups{{"a"}, {"b"}}));
  EXPECT_EQ(mapGroups({"a"}, {}), (Groups{{"a"}}));  // fewer loop lists than robots
}

TEST(OdomTransforms, ArePlanarBaseMotionUnderATiltedRaisedCamera) {
  CameraMount mount;
  mount.xyz_m = {0.2, 0.05, 0.4};
  mount.rpy_deg = {0.0, 10.0, 0.0};  // tilted 10 degrees down
  const SE3 T_base_camera = mount.T_base_camera();
  // The base drives 1 m forward and turns 30 degrees; the camera's odometry sees the conjugate motion, and
  // the map of the first robot is its base at the start (the server's T_map_odom = the mount).
  SE3 motion = SE3::Identity();
  motion.linear() = Eigen::AngleAxisd(30.0 * M_PI / 180.0, Vec3::UnitZ()).toRotationMatrix();
  motion.translation() = Vec3(1.0, 0.3, 0.0);
  const SE3 T_odom_cam = T_base_camera.inverse() * motion * T_base_camera;
  const SE3 T_map_odom = T_base_camera;
  const OdomTransforms t = odomTransforms(T_map_odom, T_map_odom * T_odom_cam, T_base_camera);
  EXPECT_LT((t.T_map_odom.matrix() - SE3::Identity().matrix()).norm(), 1e-12);
  EXPECT_LT((t.T_odom_base.matrix() - motion.matrix()).norm(), 1e-12);  // z-up, planar
  // Whatever the poses, map -> odom -> base is the base's pose in the map.
  const SE3 T_map_cam = se3::exp((Vec6() << 0.3, -1, 2, 0.1, 0.2, -0.3).finished());
  const SE3 other = se3::exp((Vec6() << 1, 2, 0.5, -0.2, 0.1, 0.4).finished());
  const OdomTransforms u = odomTransforms(other, T_map_cam, T_base_camera);
  EXPECT_LT(((u.T_map_odom * u.T_odom_base).matrix() - baseOf(T_map_cam, T_base_camera).matrix()).norm(),
            1e-12);
}

TEST(PointCloud, SixteenLittleEndianBytesAPointWithPackedRgb) {
  const std::vector<viewer::Voxel> voxels = {{1.5f, -2.0f, 0.0f}, {0.0f, 0.0f, 3.0f}};
  const std::vector<uint8_t> data = pointCloudData(voxels);
  ASSERT_EQ(data.size(), 32u);
  float x = 0, z = 0;
  uint32_t low = 0, high = 0;
  std::memcpy(&x, data.data(), 4);
  std::memcpy(&z, data.data() + 24, 4);
  std::memcpy(&low, data.data() + 12, 4);
  std::memcpy(&high, data.data() + 28, 4);
  EXPECT_EQ(x, 1.5f);
  EXPECT_EQ(z, 3.0f);
  EXPECT_EQ(low & 0xff000000u, 0u);    // 0x00RRGGBB
  EXPECT_GT(low & 0xff, low >> 16);    // the lowest voxel blue
  EXPECT_GT(high >> 16, high & 0xff);  // the highest red
  EXPECT_TRUE(pointCloudData({}).empty());
}

TEST(RosNames, RobotIdsBecomeNameTokens) {
  EXPECT_EQ(rosNameToken("robot0"), "robot0");
  EXPECT_EQ(rosNameToken("robot-1.a"), "robot_1_a");
  EXPECT_EQ(rosNameToken("7up"), "_7up");
  EXPECT_EQ(rosNameToken(""), "_");
  EXPECT_EQ(ddsTopicName("/robot0/pose"), "rt/robot0/pose");
  EXPECT_EQ(ddsTopicName("map"), "rt/map");
}

TEST(BridgeCreate, RefusesRobotsWhoseNamesCollideAndRobotsWithoutKeys) {
  BridgeOptions o;
  o.robots = {"robot-1", "robot_1"};
  o.open = true;
  auto made = Bridge::create(o, msg::KeyStore());
  ASSERT_FALSE(made);
  EXPECT_NE(made.error().find("same ROS name 'robot_1'"), std::string::npos) << made.error();
  o.robots = {"robot0"};
  o.open = false;
  EXPECT_FALSE(Bridge::create(o, msg::KeyStore()));
  o.open = true;
  EXPECT_TRUE(Bridge::create(o, msg::KeyStore()));
}

}  // namespace
}  // namespace rgbdmap::ros2
