// buildCorrections (rgbdmap_server, private): what each robot is told after an optimisation, as a pure
// function of the keyframes' optimised poses and the robots' current sessions.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "rgbdmap/ingest/pose_corrections.hpp"
#include "rgbdmap/proto/validate.hpp"

namespace rgbdmap {
namespace {

SE3 pose(double x, double yaw) {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, 0.5 * x, 0.1);
  return T;
}

IndexedNode node(int64_t id, const std::string& robot, int64_t session, int keyframe_id) {
  IndexedNode n;
  n.valid = true;
  n.kf.node_id = id;
  n.kf.robot_id = robot;
  n.kf.session = session;
  n.kf.keyframe_id = keyframe_id;
  n.kf.T_map_kf = pose(0.3 * static_cast<double>(id), 0.05 * static_cast<double>(id));
  n.kf.T_odom_kf = pose(0.25 * static_cast<double>(id), 0.04 * static_cast<double>(id));
  return n;
}

TEST(PoseCorrections, CurrentSessionsOnlyWithTheNewestKeyframesOdometry) {
  std::vector<IndexedNode> nodes;
  nodes.push_back(node(0, "a", 1, 0));  // a's previous process: not corrected any more
  nodes.push_back(node(1, "a", 1, 1));
  nodes.push_back(node(2, "b", 7, 0));
  nodes.push_back(IndexedNode{});       // a hole (lost record)
  nodes.push_back(node(4, "a", 2, 0));  // a's current process
  nodes.push_back(node(5, "b", 7, 1));
  nodes.push_back(node(6, "a", 2, 1));
  nodes.push_back(node(7, "c", 3, 0));  // c restarted (session 4) and sent nothing yet
  const std::map<std::string, int64_t> sessions{{"a", 2}, {"b", 7}, {"c", 4}};

  const auto out = buildCorrections(nodes, sessions, 42);
  ASSERT_EQ(out.size(), 2u);
  ASSERT_EQ(out.count("c"), 0u);
  const msg::PoseCorrections& a = out.at("a");
  EXPECT_EQ(a.robot_id, "a");
  EXPECT_EQ(a.graph_revision, 42);
  ASSERT_EQ(a.keyframes.size(), 2u);
  EXPECT_EQ(a.keyframes[0].keyframe_id, 0);
  EXPECT_TRUE(a.keyframes[0].T_map_cam.isApprox(nodes[4].kf.T_map_kf, 1e-12));
  EXPECT_EQ(a.keyframes[1].keyframe_id, 1);
  const SE3 T_map_odom_a = nodes[6].kf.T_map_kf * nodes[6].kf.T_odom_kf.inverse();
  EXPECT_TRUE(a.T_map_odom.isApprox(T_map_odom_a, 1e-9));
  const msg::PoseCorrections& b = out.at("b");
  ASSERT_EQ(b.keyframes.size(), 2u);
  EXPECT_TRUE(b.T_map_odom.isApprox(nodes[5].kf.T_map_kf * nodes[5].kf.T_odom_kf.inverse(), 1e-9));
}

TEST(PoseCorrections, RobotsWithoutACurrentSessionGetNothing) {
  const std::vector<IndexedNode> nodes{node(0, "a", 5, 0)};
  EXPECT_TRUE(buildCorrections(nodes, {}, 1).empty()) << "a robot missing from the sessions has session 0";
  EXPECT_TRUE(buildCorrections({}, {{"a", 5}}, 1).empty());
}

TEST(PoseCorrections, KeepsTheNewestKeyframesWithinTheMessageLimit) {
  std::vector<IndexedNode> nodes;
  const int n = msg::kMaxCorrections + 3;
  nodes.reserve(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) nodes.push_back(node(i, "a", 1, i));
  const auto out = buildCorrections(nodes, {{"a", 1}}, 9);
  const msg::PoseCorrections& a = out.at("a");
  ASSERT_EQ(a.keyframes.size(), static_cast<size_t>(msg::kMaxCorrections));
  EXPECT_EQ(a.keyframes.front().keyframe_id, 3);
  EXPECT_EQ(a.keyframes.back().keyframe_id, n - 1);
}

}  // namespace
}  // namespace rgbdmap

namespace rgbdmap {
namespace {

PoseGraphEdge graphEdge(int64_t id, int64_t from, int64_t to, EdgeKind kind) {
  PoseGraphEdge e;
  e.id = id;
  e.from = from;
  e.to = to;
  e.kind = kind;
  return e;
}

TEST(LoopEdgesMessage, EnabledLoopsOfEachRobotsMapWithOptimisedPositions) {
  std::vector<IndexedNode> nodes;
  for (int i = 0; i < 4; ++i) nodes.push_back(node(i, "a", 1, i));
  nodes.push_back(node(4, "b", 1, 0));
  nodes.push_back(node(5, "c", 1, 0));  // c: a map of its own
  for (int i = 0; i < 5; ++i) nodes[i].kf.map_id = 0;
  nodes[5].kf.map_id = 5;
  const std::vector<PoseGraphEdge> edges = {
      graphEdge(0, 0, 1, EdgeKind::kOdometry), graphEdge(1, 3, 0, EdgeKind::kLoop),
      graphEdge(2, 4, 2, EdgeKind::kInterRobot), graphEdge(3, 3, 1, EdgeKind::kLoop),  // 3: disabled
      graphEdge(4, 2, 9, EdgeKind::kLoop)};  // names a node that does not exist
  const auto out = buildLoopEdges(nodes, edges, {3}, {"a", "b", "c"}, 7);
  ASSERT_EQ(out.size(), 3u);
  const msg::LoopEdges& a = out.at("a");
  EXPECT_EQ(a.graph_revision, 7);
  ASSERT_EQ(a.edges.size(), 2u);
  EXPECT_EQ(a.edges[0].robot_from, "a");
  EXPECT_EQ(a.edges[0].keyframe_from, 3);
  EXPECT_EQ(a.edges[0].keyframe_to, 0);
  EXPECT_FALSE(a.edges[0].inter_robot);
  EXPECT_TRUE(a.edges[0].p_from.isApprox(nodes[3].kf.T_map_kf.translation()));
  EXPECT_EQ(a.edges[1].robot_from, "b");
  EXPECT_TRUE(a.edges[1].inter_robot);
  EXPECT_EQ(out.at("b").edges.size(), 2u);  // the same merged map
  EXPECT_TRUE(out.at("c").edges.empty());
  msg::LoopEdges sent = a;  // as the publisher seals it
  sent.header.sender = msg::kServerId;
  EXPECT_TRUE(msg::validate(sent)) << msg::validate(sent).error();
}

// A fleet's map has tens of thousands of loops; each robot gets the newest loop_edges_max of its
// map (in graph order), the same list for every robot of the map.
TEST(LoopEdgesMessage, OnlyTheNewestEdgesOfAMapUpToTheCap) {
  std::vector<IndexedNode> nodes;
  for (int i = 0; i < 10; ++i) nodes.push_back(node(i, i < 5 ? "a" : "b", 1, i));
  for (IndexedNode& n : nodes) n.kf.map_id = 0;
  nodes.push_back(node(10, "c", 1, 0));
  nodes[10].kf.map_id = 10;
  std::vector<PoseGraphEdge> edges;
  for (int i = 1; i < 10; ++i) edges.push_back(graphEdge(i - 1, i, i - 1, EdgeKind::kLoop));
  edges.push_back(graphEdge(9, 10, 9, EdgeKind::kOdometry));  // odometry: never listed
  const auto out = buildLoopEdges(nodes, edges, {7}, {"a", "b", "c"}, 3, 3);
  ASSERT_EQ(out.at("a").edges.size(), 3u);
  std::vector<int> from;
  for (const msg::MapLoopEdge& e : out.at("a").edges) from.push_back(static_cast<int>(e.keyframe_from));
  EXPECT_EQ(from, (std::vector<int>{6, 7, 9}))
      << "the newest three enabled ones (edge 7, from keyframe 8, is disabled)";
  EXPECT_EQ(out.at("b").edges.size(), 3u);
  EXPECT_TRUE(out.at("c").edges.empty());
  EXPECT_TRUE(buildLoopEdges(nodes, edges, {}, {"a"}, 3, 0).at("a").edges.empty());
}

}  // namespace
}  // namespace rgbdmap
