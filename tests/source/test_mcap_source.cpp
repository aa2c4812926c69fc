// mcap: sources on rosbag2-style MCAP files (ROS 2 CDR sensor_msgs on the realsense2_camera topics): every
// chunk compression gives the folder's frames exactly (32FC1) and the same odometry; a file cut off
// mid-write reads up to the cut; missing topics, wrong types and foreign files fail with a reason.
#include <filesystem>

#include <gtest/gtest.h>

#include "source/mcap_test_writer.hpp"
#include "source/source_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::McapWriteOptions;

class McapSourceTest : public ::testing::Test {
 protected:
  std::string writeMcap(const McapWriteOptions& options, const std::string& name = "test.mcap") {
    const std::string path = dir_.path(name);
    const Status s = testing::writeTumFolderAsMcap(testing::sourceTestFolder(), path,
                                                   testing::sourceTestConfig().camera, options);
    EXPECT_TRUE(s) << s.error();
    return path;
  }
  static std::vector<RgbdFrame> folderFrames() { return testing::sourceTestFrames(); }
  static std::string openError(const std::string& url) { return testing::openSourceError(url); }
  testing::TempDir dir_;
};

TEST_F(McapSourceTest, EveryCompressionGivesTheFoldersFramesExactly) {
  const auto from_folder = folderFrames();
  ASSERT_FALSE(from_folder.empty());
  for (mcap::Compression c : {mcap::Compression::kZstd, mcap::Compression::kLz4, mcap::Compression::kNone}) {
    McapWriteOptions o;
    o.compression = c;
    auto source = testing::openOrFail("mcap:" + writeMcap(o), {});
    ASSERT_TRUE(source);
    EXPECT_FALSE(source->live());
    const auto camera = source->camera();
    ASSERT_TRUE(camera);  // from camera_info
    const CameraIntrinsics& truth = testing::sourceTestConfig().camera;
    EXPECT_EQ(camera->fx, truth.fx);
    EXPECT_EQ(camera->cy, truth.cy);
    EXPECT_EQ(camera->depth_scale, 5000.0);
    const auto frames = testing::drainSource(*source);
    ASSERT_EQ(frames.size(), from_folder.size()) << mcap::compressionName(c);
    for (size_t i = 0; i < frames.size(); ++i) {
      EXPECT_NEAR(frames[i].timestamp, from_folder[i].timestamp, 1e-6) << i;
      EXPECT_EQ(cv::norm(frames[i].color, from_folder[i].color, cv::NORM_INF), 0.0) << i;
      EXPECT_EQ(cv::norm(frames[i].depth, from_folder[i].depth, cv::NORM_INF), 0.0) << i;
    }
  }
}

TEST_F(McapSourceTest, Depth16UC1AndRgb8AreRead) {
  McapWriteOptions o;
  o.depth_encoding = "16UC1";
  o.color_encoding = "rgb8";
  auto source = testing::openOrFail("mcap:" + writeMcap(o), {});
  ASSERT_TRUE(source);
  EXPECT_EQ(source->camera()->depth_scale, 1000.0);
  const auto frames = testing::drainSource(*source);
  const auto from_folder = folderFrames();
  ASSERT_EQ(frames.size(), from_folder.size());
  cv::Mat mm;
  from_folder[3].depth.convertTo(mm, CV_16UC1, 1000.0 / 5000.0);
  EXPECT_EQ(cv::norm(frames[3].depth, mm, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(frames[3].color, from_folder[3].color, cv::NORM_INF), 0.0);
}

TEST_F(McapSourceTest, ACutOffRecordingReadsUpToTheCut) {
  McapWriteOptions o;
  o.chunk_bytes = 1 << 18;  // several chunks
  const std::string whole = writeMcap(o);
  const auto size = std::filesystem::file_size(whole);
  std::filesystem::copy_file(whole, dir_.path("cut.mcap"));
  std::filesystem::resize_file(dir_.path("cut.mcap"), size * 6 / 10);
  auto source = testing::openOrFail("mcap:" + dir_.path("cut.mcap"), {});
  ASSERT_TRUE(source);
  const auto frames = testing::drainSource(*source);
  const auto from_folder = folderFrames();
  EXPECT_GT(frames.size(), 3u);
  EXPECT_LT(frames.size(), from_folder.size());
  for (size_t i = 0; i < frames.size(); ++i)
    EXPECT_EQ(cv::norm(frames[i].depth, from_folder[i].depth, cv::NORM_INF), 0.0) << i;
}

TEST_F(McapSourceTest, MissingTopicsWrongTypesAndForeignFilesAreNamed) {
  const std::string file = writeMcap({});
  const std::string no_topic = openError("mcap:" + file + "?rgb=/nope");
  EXPECT_NE(no_topic.find("no sensor_msgs/msg/Image on /nope"), std::string::npos) << no_topic;
  EXPECT_NE(no_topic.find("/camera/camera/color/image_raw (sensor_msgs/msg/Image)"), std::string::npos)
      << no_topic;
  const std::string wrong_type = openError("mcap:" + file + "?rgb=/camera/camera/color/camera_info");
  EXPECT_NE(wrong_type.find("is sensor_msgs/msg/CameraInfo, expected sensor_msgs/msg/Image"),
            std::string::npos)
      << wrong_type;
  const std::string no_info = openError("mcap:" + file + "?info=/nope");
  EXPECT_NE(no_info.find("no sensor_msgs/msg/CameraInfo on /nope"), std::string::npos) << no_info;
  EXPECT_NE(openError("mcap:" + dir_.path("absent.mcap")).find("cannot open"), std::string::npos);
  const std::string bag = openError("mcap:" + testing::sourceTestFolder() + "/rgb.txt");
  EXPECT_NE(bag.find("not an MCAP file"), std::string::npos) << bag;
  EXPECT_NE(openError("mcap:" + file + "?max_dt=x").find("max_dt must be seconds"), std::string::npos);
}

}  // namespace
}  // namespace rgbdmap
