// The map worker's memory bound: when the octree falls behind ingestion, keyframe jobs beyond
// MapWorker::kMaxQueuedImages wait without their decoded images and read them back from the store; every
// keyframe still reaches the octree. (A private class of the server library, tested directly: the worker is
// not started until the jobs are queued, the way a slow octree lets them pile up.)
#include <filesystem>

#include <gtest/gtest.h>

#include "../../server/core/src/map_worker.hpp"
#include "rgbdmap/proto/codec.hpp"
#include "server/server_test_util.hpp"

namespace rgbdmap {
namespace {

TEST(MapWorkerBound, JobsBeyondTheBoundReadTheirImagesBackAndAllAreInserted) {
  const testing::OdometrySegment& seg = testing::loopSegment(testing::kLoopFrames, 0, testing::kLoopFrames);
  const size_t n = std::min<size_t>(seg.keyframes.size(), MapWorker::kMaxQueuedImages + 8);
  ASSERT_GT(n, MapWorker::kMaxQueuedImages);
  const std::string dir = testing::freshDir("map_worker_bound");
  auto store = MapStore::open(dir);
  ASSERT_TRUE(store) << store.error();
  MapServerConfig config = testing::serverTestConfig(dir);
  config.map_stream_period_s = 0.0;
  MapWorker worker(config, **store, {});
  for (size_t i = 0; i < n; ++i) {
    StoredKeyframe stored;
    stored.node_id = static_cast<int64_t>(i);
    stored.session = 1;
    stored.keyframe = seg.keyframes[i];
    ASSERT_TRUE((*store)->appendKeyframe(stored));
    const Result<DecodedImages> images = msg::decodeKeyframeImages(seg.keyframes[i]);
    ASSERT_TRUE(images) << images.error();
    MapKeyframeJob job;
    job.node_id = stored.node_id;
    job.robot_id = "robot0";
    job.T_map_kf = seg.keyframes[i].T_odom_cam;
    job.camera = seg.camera;
    job.depth = images->depth;
    job.color = images->color;
    job.live = false;  // no slices: no publishers here
    worker.addKeyframe(std::move(job));
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
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rgbdmap
