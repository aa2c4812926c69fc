// Unit tests of the viewer library's pieces (no network): the Foxglove JSON (schemas, base64, messages) and
// a client session's queue (subscriptions, dropping and counting for a slow reader, snapshots after drops).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include <octomap/OcTree.h>

#include "rgbdmap/map/map_io.hpp"
#include "rgbdmap/proto/map_payload.hpp"
#include "rgbdmap/viewer/client_session.hpp"
#include "rgbdmap/viewer/foxglove_json.hpp"
#include "rgbdmap/viewer/map_view.hpp"

namespace rgbdmap::viewer {
namespace {

TEST(ViewerJson, Base64MatchesKnownVectors) {
  const std::string text = "foobar";
  const auto* bytes = reinterpret_cast<const uint8_t*>(text.data());
  EXPECT_EQ(base64(bytes, 0), "");
  EXPECT_EQ(base64(bytes, 1), "Zg==");
  EXPECT_EQ(base64(bytes, 2), "Zm8=");
  EXPECT_EQ(base64(bytes, 3), "Zm9v");
  EXPECT_EQ(base64(bytes, 6), "Zm9vYmFy");
}

TEST(ViewerJson, EverySchemaIsJsonWithItsTitle) {
  for (const char* name :
       {"foxglove.PointCloud", "foxglove.PosesInFrame", "foxglove.PoseInFrame", "foxglove.FrameTransforms",
        "foxglove.Grid", "rgbdmap.VoxelDelta", "rgbdmap.RobotStatus"}) {
    const nlohmann::json schema = nlohmann::json::parse(schemaFor(name));
    EXPECT_EQ(schema["title"], name);
    EXPECT_EQ(schema["type"], "object");
  }
  EXPECT_EQ(schemaFor("foxglove.Unknown"), "");
}

TEST(ViewerJson, PointCloudPacksPointsAndColoursByHeight) {
  const std::vector<Voxel> voxels = {{1.0f, 0.0f, 2.0f}, {1.0f, 0.0f, 3.0f}};  // the second is 1 m higher
  EXPECT_EQ(heightOf(voxels[1]) - heightOf(voxels[0]), 1.0f) << "the map frame is z-up";
  const nlohmann::json cloud = pointCloudJson(voxels, 1500000, "map");
  EXPECT_EQ(cloud["point_stride"], 16);
  EXPECT_EQ(cloud["frame_id"], "map");
  EXPECT_EQ(cloud["timestamp"]["sec"], 1);
  EXPECT_EQ(cloud["timestamp"]["nsec"], 500000000);
  EXPECT_EQ(cloud["data"].get<std::string>().size(), 4u * ((2u * 16u + 2u) / 3u));  // 32 bytes -> 44 chars
  uint8_t low[3], high[3];
  heightColour(0.0f, 0.0f, 1.0f, low);
  heightColour(1.0f, 0.0f, 1.0f, high);
  EXPECT_GT(low[2], low[0]);    // low: blue
  EXPECT_GT(high[0], high[2]);  // high: red
}

TEST(ViewerJson, PoseAndTransformCarryTranslationAndUnitQuaternion) {
  SE3 T = SE3::Identity();
  T.translation() = Vec3(1, 2, 3);
  T.linear() = Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix();
  const nlohmann::json tf = frameTransformsJson({{"map", "robot0", T}}, 0);
  const nlohmann::json& t = tf["transforms"][0];
  EXPECT_EQ(t["parent_frame_id"], "map");
  EXPECT_EQ(t["child_frame_id"], "robot0");
  EXPECT_DOUBLE_EQ(t["translation"]["y"].get<double>(), 2.0);
  EXPECT_NEAR(t["rotation"]["z"].get<double>(), std::sin(0.25), 1e-12);
}

TEST(ViewerJson, LoopEdgesAreOneLineListWithInterRobotColours) {
  std::vector<msg::MapLoopEdge> loops = {{"a", 1, "a", 5, false, Vec3(0, 0, 0), Vec3(1, 0, 0)},
                                         {"a", 2, "b", 3, true, Vec3(0, 1, 0), Vec3(0, 2, 0)}};
  const nlohmann::json scene = loopEdgesJson(loops, 0, "map", "a/loops");
  ASSERT_EQ(scene["entities"].size(), 1u);
  const nlohmann::json& line = scene["entities"][0]["lines"][0];
  EXPECT_EQ(line["type"], 2);  // LINE_LIST
  ASSERT_EQ(line["points"].size(), 4u);
  EXPECT_DOUBLE_EQ(line["points"][1]["x"].get<double>(), 1.0);
  EXPECT_NE(line["colors"][0], line["colors"][2]);  // a loop and an inter-robot loop differ
  EXPECT_TRUE(scene["entities"][0]["cubes"].is_array());
  EXPECT_EQ(nlohmann::json::parse(schemaFor("foxglove.SceneUpdate"))["title"], "foxglove.SceneUpdate");
}

/// A writer that blocks until released (a client that does not read), recording what it wrote.
struct BlockingWriter {
  std::mutex mutex;
  std::condition_variable cv;
  bool open = false;
  std::vector<std::string> frames;
  ClientSession::Writer writer() {
    return [this](bool, const std::string& bytes) {
      std::unique_lock<std::mutex> lock(mutex);
      cv.wait(lock, [&] { return open; });
      frames.push_back(bytes);
      return true;
    };
  }
  void release() {
    std::lock_guard<std::mutex> lock(mutex);
    open = true;
    cv.notify_all();
  }
  size_t count() {
    std::lock_guard<std::mutex> lock(mutex);
    return frames.size();
  }
};

bool eventually(const std::function<bool()>& condition) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return condition();
}

TEST(ViewerSession, SendsOnlySubscribedChannelsAsMessageData) {
  BlockingWriter w;
  w.release();
  ClientSession session(1, SessionLimits{}, w.writer(), nullptr);
  session.start();
  const auto payload = std::make_shared<const std::string>("{}");
  EXPECT_FALSE(session.sendMessage(3, payload, 7, false));
  EXPECT_EQ(session.subscribe(42, 3), "");
  EXPECT_NE(session.subscribe(42, 4), "");  // id in use
  EXPECT_NE(session.subscribe(43, 3), "");  // channel already subscribed
  EXPECT_TRUE(session.sendMessage(3, payload, 7, false));
  ASSERT_TRUE(eventually([&] { return w.count() == 1; }));
  const std::string& frame = w.frames[0];
  ASSERT_EQ(frame.size(), 15u);
  EXPECT_EQ(frame[0], 0x01);
  EXPECT_EQ(static_cast<uint8_t>(frame[1]), 42);  // subscription id, little endian
  EXPECT_EQ(static_cast<uint8_t>(frame[5]), 7);   // time
  EXPECT_EQ(frame.substr(13), "{}");
  EXPECT_TRUE(session.unsubscribe(42));
  EXPECT_FALSE(session.sendMessage(3, payload, 7, false));
  session.close();
}

TEST(ViewerSession, SlowReaderDropsAndCountsThenCatchesUpWithSnapshotAndLatest) {
  BlockingWriter w;  // not reading until released
  SessionLimits limits;
  limits.max_queue_messages = 4;
  std::atomic<int> resent_latest{0};
  ClientSession session(1, limits, w.writer(), [&](ClientSession&, uint32_t channel) {
    if (channel == 1) ++resent_latest;
  });
  session.start();
  ASSERT_EQ(session.subscribe(10, 1), "");  // a latest-state channel
  ASSERT_EQ(session.subscribe(11, 2), "");  // an incremental channel
  const auto payload = std::make_shared<const std::string>(std::string(100, 'x'));
  EXPECT_TRUE(session.awaitsSnapshot(2));
  EXPECT_FALSE(session.sendMessage(2, payload, 0, true));  // no deltas before the snapshot
  EXPECT_TRUE(session.sendSnapshot(2, payload, 0, false));
  EXPECT_FALSE(session.awaitsSnapshot(2));
  int accepted = 1;
  for (int i = 0; i < 100; ++i)
    accepted += session.sendMessage(i % 2 ? 2 : 1, payload, 0, i % 2 == 1) ? 1 : 0;
  EXPECT_LE(accepted, 5);  // 4 queued + at most the one being written
  // Every latest-state message beyond the queue is dropped and counted; after the first dropped delta the
  // others are held back (the client waits for a snapshot), not queued.
  EXPECT_GE(session.counters().dropped_messages, 46u);
  EXPECT_TRUE(session.awaitsSnapshot(2));  // a delta was dropped: the next one must be a snapshot
  w.release();
  ASSERT_TRUE(eventually([&] { return resent_latest.load() == 1; }));  // the dropped latest, once drained
  ASSERT_TRUE(
      eventually([&] { return session.counters().messages_sent == static_cast<uint64_t>(accepted); }));
  session.close();
}

/// A pose translated along x.
SE3 at(double x) {
  SE3 T = SE3::Identity();
  T.translation().x() = x;
  return T;
}

TEST(ViewerPose, LivePoseWhenFreshAndCurrentElseNewestKeyframe) {
  RobotSnapshot s;
  bool live = true;
  EXPECT_FALSE(currentPose(s, 1000000, &live));
  s.keyframes = {{0, at(1.0)}, {4, at(2.0)}};
  s.graph_revision = 3;
  EXPECT_TRUE(currentPose(s, 1000000, &live)->isApprox(at(2.0)));
  EXPECT_FALSE(live);
  msg::RobotPose p;
  p.graph_revision = 3;
  p.T_map_cam = at(2.5);
  s.live_pose = p;
  s.live_pose_received_utime = 1000000;
  EXPECT_TRUE(currentPose(s, 1500000, &live)->isApprox(at(2.5)));
  EXPECT_TRUE(live);
  EXPECT_TRUE(currentPose(s, 1000000 + int64_t(kLivePoseMaxAgeS * 1e6) + 1, &live)->isApprox(at(2.0)))
      << "a robot no longer heard: its newest keyframe";
  EXPECT_FALSE(live);
  s.graph_revision = 4;  // newer corrections than the robot applied: its pose is in the old map
  EXPECT_TRUE(currentPose(s, 1500000, &live)->isApprox(at(2.0)));
  EXPECT_FALSE(live);
}

TEST(ViewerPose, RobotPosesApplyInOrderPerSession) {
  MapView view({"robot0"});
  msg::RobotPose p;
  p.robot_id = "robot0";
  p.header.session = 7;
  p.header.utime = 2000;
  p.T_map_cam = at(1.0);
  view.applyRobotPose("robot0", p);
  msg::RobotPose older = p;
  older.header.utime = 1000;
  older.T_map_cam = at(9.0);
  view.applyRobotPose("robot0", older);  // reordered: dropped
  EXPECT_TRUE(view.snapshot("robot0").live_pose->T_map_cam.isApprox(at(1.0)));
  EXPECT_EQ(view.snapshot("robot0").live_changes, 1u);
  msg::RobotPose restarted = older;
  restarted.header.session = 8;  // a restarted robot's clock may be anywhere
  view.applyRobotPose("robot0", restarted);
  EXPECT_TRUE(view.snapshot("robot0").live_pose->T_map_cam.isApprox(at(9.0)));
  view.applyRobotPose("nobody", p);
  EXPECT_FALSE(view.snapshot("nobody").live_pose);
}

TEST(ViewerLink, TheRobotsLinkStatusIsKeptInOrderPerSession) {
  MapView view({"robot0"});
  msg::LinkStatus l;
  l.robot_id = "robot0";
  l.header.session = 7;
  l.header.utime = 2000;
  l.spool_depth = 12;
  l.oldest_unanswered_s = 30.5;
  view.applyLinkStatus("robot0", l);
  msg::LinkStatus older = l;
  older.header.utime = 1000;
  older.spool_depth = 40;
  view.applyLinkStatus("robot0", older);  // reordered: dropped
  ASSERT_TRUE(view.snapshot("robot0").link);
  EXPECT_EQ(view.snapshot("robot0").link->spool_depth, 12);
  EXPECT_EQ(view.snapshot("robot0").status_changes, 1u) << "republishes /robot0/status";
  view.applyLinkStatus("nobody", l);
  EXPECT_FALSE(view.snapshot("nobody").link);
}

TEST(ViewerMapGrid, CutFromTheStreamedTreeAndKeyframeIdKept) {
  MapView view({"robot0"});
  EXPECT_FALSE(view.mapGrid("robot0", 0.0, SliceConfig{})) << "no map yet";
  octomap::OcTree tree(0.05);
  for (int i = 0; i < 20; ++i) tree.updateNode(octomap::point3d(0.025f + 0.05f * i, 0.025f, 0.025f), false);
  tree.updateNode(octomap::point3d(1.025f, 0.025f, 0.025f), true);
  auto bytes = serializeTree(tree);
  ASSERT_TRUE(bytes) << bytes.error();
  msg::MapUpdate update;
  update.header.utime = 5;
  update.map_revision = 1;
  update.robot_keyframe_id = 12;
  msg::setMapBytes(*bytes, msg::MapCompression::kNone, &update);
  ASSERT_TRUE(view.applyMap("robot0", update));
  EXPECT_EQ(view.snapshot("robot0").map_keyframe_id, 12);
  auto grid = view.mapGrid("robot0", 0.0, SliceConfig{});
  ASSERT_TRUE(grid) << grid.error();
  EXPECT_TRUE(grid->T_map_grid.linear().isApprox(Mat3::Identity())) << "no yaw";
  EXPECT_EQ(std::count(grid->cells.begin(), grid->cells.end(), 100), 1);
  EXPECT_GE(std::count(grid->cells.begin(), grid->cells.end(), 0), 19);
  const nlohmann::json j = gridJson(*grid, "map");
  EXPECT_EQ(j["column_count"], grid->width);
  EXPECT_EQ(j["pose"]["orientation"]["w"], 1.0);
}

}  // namespace
}  // namespace rgbdmap::viewer
