// --source URL parsing, the TUM source, ranges, recording to a TUM folder.
#include <gtest/gtest.h>

#include "rgbdmap/source/frame_recorder.hpp"
#include "rgbdmap/source/live_source.hpp"
#include "source/source_test_util.hpp"

namespace rgbdmap {
namespace {

TEST(SourceUrl, ParsesSchemesPathsAndQueries) {
  auto bag = SourceUrl::parse("bag:/data/x.bag?rgb=/a/b&depth=/c&info=/d");
  ASSERT_TRUE(bag) << bag.error();
  EXPECT_EQ(bag->scheme, "bag");
  EXPECT_EQ(bag->path, "/data/x.bag");
  EXPECT_EQ(bag->get("rgb", ""), "/a/b");
  EXPECT_EQ(bag->get("depth", ""), "/c");
  EXPECT_EQ(bag->get("info", ""), "/d");
  auto tum = SourceUrl::parse("tum://rel/dir");
  ASSERT_TRUE(tum);
  EXPECT_EQ(tum->path, "rel/dir");
  auto live = SourceUrl::parse("tum:dir?live");
  ASSERT_TRUE(live);
  EXPECT_TRUE(live->query.count("live"));
  auto device = SourceUrl::parse("openni2:");
  ASSERT_TRUE(device);
  EXPECT_TRUE(device->path.empty());
}

TEST(SourceUrl, RejectsWhatItCannotRead) {
  EXPECT_NE(SourceUrl::parse("x.bag").error().find("expected tum:DIR"), std::string::npos);
  EXPECT_NE(SourceUrl::parse("realsense:0").error().find("unknown kind 'realsense'"), std::string::npos);
  EXPECT_NE(SourceUrl::parse("bag:x.bag?colour=/a").error().find("unknown option 'colour'"),
            std::string::npos);
  EXPECT_NE(SourceUrl::parse("bag:").error().find("file missing"), std::string::npos);
  EXPECT_NE(SourceUrl::parse("tum:?live").error().find("folder missing"), std::string::npos);
  EXPECT_NE(SourceUrl::parse("bag:x.bag?=3").error().find("empty key"), std::string::npos);
}

TEST(TumSource, YieldsTheDatasetsFramesInRange) {
  const SynthConfig config = testing::sourceTestConfig();
  SourceOptions o = testing::sourceOptionsFor(config.camera);
  o.first_frame = 5;
  o.end_frame = 12;
  auto source = testing::openOrFail("tum:" + testing::sourceTestFolder(), o);
  ASSERT_TRUE(source);
  EXPECT_FALSE(source->live());
  EXPECT_EQ(source->sizeHint(), 7u);
  ASSERT_TRUE(source->camera());
  EXPECT_EQ(source->camera()->fx, config.camera.fx);
  ASSERT_TRUE(source->groundTruth());
  const auto frames = testing::drainSource(*source);
  ASSERT_EQ(frames.size(), 7u);
  EXPECT_NEAR(frames.front().timestamp, config.colorTimestamp(5), 1e-6);
  EXPECT_NEAR(frames.back().timestamp, config.colorTimestamp(11), 1e-6);
}

TEST(TumSource, MissingFolderNamesIt) {
  auto url = SourceUrl::parse("tum:/nonexistent/seq");
  ASSERT_TRUE(url);
  auto source = openFrameSource(*url, {});
  ASSERT_FALSE(source);
  EXPECT_NE(source.error().find("/nonexistent/seq"), std::string::npos) << source.error();
}

TEST(RecordingSource, WritesAFolderThatReplaysTheSameFrames) {
  const SynthConfig config = testing::sourceTestConfig();
  testing::TempDir out;
  auto source =
      testing::openOrFail("tum:" + testing::sourceTestFolder(), testing::sourceOptionsFor(config.camera));
  ASSERT_TRUE(source);
  auto recorder = TumRecorder::create(out.path("rec"), config.camera);
  ASSERT_TRUE(recorder) << recorder.error();
  RecordingSource recording(std::move(source), std::move(*recorder));
  const auto original = testing::drainSource(recording);
  ASSERT_TRUE(recording.finish());
  EXPECT_EQ(recording.recorded(), original.size());
  auto replay = testing::openOrFail("tum:" + out.path("rec"), testing::sourceOptionsFor(config.camera));
  ASSERT_TRUE(replay);
  ASSERT_TRUE(replay->camera());
  EXPECT_EQ(replay->camera()->fx, config.camera.fx);
  EXPECT_EQ(replay->camera()->depth_scale, config.camera.depth_scale);
  EXPECT_TRUE(replay->groundTruth());
  const auto replayed = testing::drainSource(*replay);
  ASSERT_EQ(replayed.size(), original.size());
  for (size_t i = 0; i < original.size(); ++i) {
    EXPECT_NEAR(replayed[i].timestamp, original[i].timestamp, 1e-6);
    EXPECT_EQ(cv::norm(replayed[i].color, original[i].color, cv::NORM_INF), 0.0) << i;
    EXPECT_EQ(cv::norm(replayed[i].depth, original[i].depth, cv::NORM_INF), 0.0) << i;
  }
}

TEST(RangeSource, SkipsAndStopsOnAnySource) {
  const SynthConfig config = testing::sourceTestConfig();
  auto inner =
      testing::openOrFail("tum:" + testing::sourceTestFolder(), testing::sourceOptionsFor(config.camera));
  ASSERT_TRUE(inner);
  auto ranged = makeRangeSource(std::move(inner), 3, 8);
  EXPECT_EQ(ranged->sizeHint(), 5u);
  const auto frames = testing::drainSource(*ranged);
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_NEAR(frames.front().timestamp, config.colorTimestamp(3), 1e-6);
}

}  // namespace
}  // namespace rgbdmap
