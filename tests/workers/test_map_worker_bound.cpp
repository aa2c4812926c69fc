// The map worker's memory bound: when the octree falls behind ingestion, keyframe jobs beyond
// MapWorker::kMaxQueuedImages wait without their decoded images and read them back from the store; every
// keyframe still reaches the octree. (A private class of the server library, tested directly: the worker is
// not started until the jobs are queued, the way a slow octree lets them pile up.)
#include <filesystem>

#include <gtest/gtest.h>

#include "rgbdmap/proto/codec.hpp"
#include "rgbdmap/workers/map_worker.hpp"
#include "server/server_test_util.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {

/// A map directory with an open store and a test configuration without a periodic map stream.
struct WorkerSetup {
  explicit WorkerSetup(const std::string& name) : dir(testing::freshDir(name)) {
    auto opened = MapStore::open(dir);
    EXPECT_TRUE(opened) << opened.error();
    if (opened) store = std::move(opened).value();
    config = testing::serverTestConfig(dir);
    config.map_stream_period_s = 0.0;
  }
  ~WorkerSetup() {
    store.reset();
    std::filesystem::remove_all(dir);
  }
  std::string dir;
  std::unique_ptr<MapStore> store;
  MapServerConfig config;
};

/// Keyframe i of the segment as a map job with its decoded images (no slices: no publishers here).
MapKeyframeJob jobFor(const testing::OdometrySegment& seg, size_t i) {
  const Result<DecodedImages> images = msg::decodeKeyframeImages(seg.keyframes[i]);
  EXPECT_TRUE(images) << images.error();
  MapKeyframeJob job;
  job.node_id = static_cast<int64_t>(i);
  job.robot_id = "robot0";
  job.T_map_kf = seg.keyframes[i].T_odom_cam;
  job.camera = seg.camera;
  if (images) {
    job.depth = images->depth;
    job.color = images->color;
  }
  job.live = false;
  return job;
}

RGBDMAP_TEST_TIER("MapWorkerBound.*", "e2e sanitize");
TEST(MapWorkerBound, JobsBeyondTheBoundReadTheirImagesBackAndAllAreInserted) {
  const testing::OdometrySegment& seg = testing::loopSegment(testing::kLoopFrames, 0, testing::kLoopFrames);
  const size_t n = std::min<size_t>(seg.keyframes.size(), MapWorker::kMaxQueuedImages + 8);
  ASSERT_GT(n, MapWorker::kMaxQueuedImages);
  WorkerSetup setup("map_worker_bound");
  ASSERT_TRUE(setup.store);
  MapWorker worker(mapWorkerConfig(setup.config), *setup.store, {});
  for (size_t i = 0; i < n; ++i) {
    StoredKeyframe stored;
    stored.node_id = static_cast<int64_t>(i);
    stored.session = 1;
    stored.keyframe = seg.keyframes[i];
    ASSERT_TRUE(setup.store->appendKeyframe(stored));
    worker.addKeyframe(jobFor(seg, i));
  }
  MapServerStats s;
  worker.fillStats(&s);
  EXPECT_EQ(s.map_images_deferred, n - MapWorker::kMaxQueuedImages);
  worker.start();
  ASSERT_TRUE(worker.waitIdle(120.0));
  worker.fillStats(&s);
  EXPECT_EQ(s.map_keyframes, n) << "a job without images was left out";
  EXPECT_GT(s.map_occupied_leaves, 1000u);
  worker.stop();
}

TEST(MapWorkerBound, PoseUpdatesQueuedBehindAKeyframeCoalesceAndReachTheKeyframesQueuedAfterIt) {
  // Each pose update holds the whole map's poses: a worker behind by thousands of keyframes must hold one,
  // not one per optimisation, and still insert every keyframe at its newest pose.
  const testing::OdometrySegment& seg = testing::loopSegment(testing::kLoopFrames, 0, testing::kLoopFrames);
  ASSERT_GE(seg.keyframes.size(), 4u);
  WorkerSetup setup("map_worker_poses");
  ASSERT_TRUE(setup.store);
  MapWorker worker(mapWorkerConfig(setup.config), *setup.store, {});
  const auto original = [&](int i) { return seg.keyframes[static_cast<size_t>(i)].T_odom_cam; };
  const auto moved = [&](int i, int epoch) {  // what optimisation `epoch` made of keyframe i
    return SE3(Eigen::Translation3d(0.01 * epoch, -0.005 * epoch, 0.0)) * original(i);
  };
  const auto add = [&](int i, uint64_t epoch) {
    MapKeyframeJob job = jobFor(seg, static_cast<size_t>(i));
    job.pose_epoch = epoch;
    worker.addKeyframe(std::move(job));
  };
  const auto update = [&](int count, int epoch) {
    std::vector<MapNodePose> poses;
    for (int i = 0; i < count; ++i) poses.push_back({i, 0, moved(i, epoch)});
    worker.updatePoses(std::move(poses), static_cast<uint64_t>(epoch));
  };
  // Queued before the worker runs, as behind a slow octree: keyframe 0, update 1, keyframe 1 (made after
  // update 1), update 2, keyframe 2 (made before update 2 reached the ingest: epoch 1), update 3 (knows
  // keyframe 3 too), keyframe 3 (made after update 3: its own pose is the newest).
  add(0, 0);
  update(1, 1);
  add(1, 1);
  update(2, 2);
  add(2, 1);
  update(4, 3);
  add(3, 3);
  MapServerStats s;
  worker.fillStats(&s);
  EXPECT_EQ(s.map_pose_updates_coalesced, 2u) << "updates 1 and 2 are replaced by 3 before they run";
  worker.start();
  ASSERT_TRUE(worker.waitIdle(120.0));
  for (int i = 0; i < 4; ++i) {
    const std::optional<MapNodePose> p = worker.insertedPose(i);
    ASSERT_TRUE(p) << "keyframe " << i << " not inserted";
    const SE3 expected = i < 3 ? moved(i, 3) : original(i);
    EXPECT_TRUE(p->T_map_kf.matrix().isApprox(expected.matrix(), 1e-12))
        << "keyframe " << i << " at\n"
        << p->T_map_kf.matrix() << "\nexpected\n"
        << expected.matrix();
  }
  worker.stop();
}

}  // namespace
}  // namespace rgbdmap
