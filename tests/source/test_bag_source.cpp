// bag: sources on bags written with the real rosbag_storage writer: the TUM bag's topics and encodings give
// the folder's frames (32FC1 exactly, 16UC1 within a millimetre) and the same odometry; bgr8 and mono8
// colour; missing topics, unsupported encodings, truncated and foreign files fail with a reason.
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "rgbdmap/client/odometry.hpp"
#include "source/bag_test_writer.hpp"
#include "source/source_test_util.hpp"

namespace rgbdmap {
namespace {

using testing::BagWriteOptions;

class BagSourceTest : public ::testing::Test {
 protected:
  std::string writeBag(const BagWriteOptions& options, const std::string& name = "test.bag") {
    const std::string path = dir_.path(name);
    const Status s = testing::writeTumFolderAsBag(testing::sourceTestFolder(), path,
                                                  testing::sourceTestConfig().camera, options);
    EXPECT_TRUE(s) << s.error();
    return path;
  }
  static std::vector<RgbdFrame> folderFrames() { return testing::sourceTestFrames(); }
  static std::string openError(const std::string& url) { return testing::openSourceError(url); }
  testing::TempDir dir_;
};

TEST_F(BagSourceTest, Tum32FC1BagGivesTheFoldersFramesExactly) {
  const std::string bag = writeBag({});
  auto source = testing::openOrFail("bag:" + bag, {});
  ASSERT_TRUE(source);
  EXPECT_FALSE(source->live());
  EXPECT_EQ(source->sizeHint(), 20u);
  const auto camera = source->camera();
  ASSERT_TRUE(camera);  // from camera_info
  const CameraIntrinsics& truth = testing::sourceTestConfig().camera;
  EXPECT_EQ(camera->fx, truth.fx);
  EXPECT_EQ(camera->cy, truth.cy);
  EXPECT_EQ(camera->width, truth.width);
  EXPECT_EQ(camera->depth_scale, 5000.0);
  const auto from_bag = testing::drainSource(*source);
  const auto from_folder = folderFrames();
  ASSERT_EQ(from_bag.size(), from_folder.size());
  for (size_t i = 0; i < from_bag.size(); ++i) {
    EXPECT_NEAR(from_bag[i].timestamp, from_folder[i].timestamp, 1e-6) << i;
    EXPECT_EQ(from_bag[i].depth_scale, 5000.0);
    EXPECT_EQ(cv::norm(from_bag[i].color, from_folder[i].color, cv::NORM_INF), 0.0) << i;
    EXPECT_EQ(cv::norm(from_bag[i].depth, from_folder[i].depth, cv::NORM_INF), 0.0) << i;  // 32FC1 exact
  }
}

TEST_F(BagSourceTest, Depth16UC1IsWithinAMillimetre) {
  BagWriteOptions o;
  o.depth_encoding = "16UC1";
  o.color_encoding = "bgr8";
  auto source = testing::openOrFail("bag:" + writeBag(o), {});
  ASSERT_TRUE(source);
  EXPECT_EQ(source->camera()->depth_scale, 1000.0);
  const auto from_bag = testing::drainSource(*source);
  const auto from_folder = folderFrames();
  ASSERT_EQ(from_bag.size(), from_folder.size());
  double worst_m = 0;
  for (size_t i = 0; i < from_bag.size(); ++i) {
    EXPECT_EQ(cv::norm(from_bag[i].color, from_folder[i].color, cv::NORM_INF), 0.0) << i;  // bgr8
    cv::Mat a, b;
    from_bag[i].depth.convertTo(a, CV_64F, 1.0 / from_bag[i].depth_scale);
    from_folder[i].depth.convertTo(b, CV_64F, 1.0 / from_folder[i].depth_scale);
    worst_m = std::max(worst_m, cv::norm(a, b, cv::NORM_INF));
  }
  EXPECT_LE(worst_m, 0.0005 + 1e-9);  // rounding to whole millimetres
  EXPECT_GT(worst_m, 0.0);            // and it did round: the test sees the 16-bit path
}

TEST_F(BagSourceTest, SameOdometryAsTheFolder) {
  auto source = testing::openOrFail("bag:" + writeBag({}), {});
  ASSERT_TRUE(source);
  const CameraIntrinsics camera = *source->camera();
  VisualOdometry from_bag(camera, {}), from_folder(testing::sourceTestConfig().camera, {});
  const auto bag_frames = testing::drainSource(*source);
  const auto folder_frames = folderFrames();
  ASSERT_EQ(bag_frames.size(), folder_frames.size());
  double worst_m = 0;
  for (size_t i = 0; i < bag_frames.size(); ++i) {
    const SE3 a = from_bag.track(bag_frames[i]).T_odom_cam;
    const SE3 b = from_folder.track(folder_frames[i]).T_odom_cam;
    worst_m = std::max(worst_m, (a.translation() - b.translation()).norm());
  }
  EXPECT_LT(worst_m, 1e-9);
}

TEST_F(BagSourceTest, CompressedChunksReadTheSame) {
  const auto from_folder = folderFrames();
  for (const char* compression : {"bz2", "lz4"}) {
    BagWriteOptions o;
    o.compression = compression;
    auto source = testing::openOrFail("bag:" + writeBag(o, std::string(compression) + ".bag"), {});
    ASSERT_TRUE(source);
    const auto frames = testing::drainSource(*source);
    ASSERT_EQ(frames.size(), from_folder.size()) << compression;
    EXPECT_EQ(cv::norm(frames.back().depth, from_folder.back().depth, cv::NORM_INF), 0.0) << compression;
    EXPECT_EQ(cv::norm(frames.back().color, from_folder.back().color, cv::NORM_INF), 0.0) << compression;
  }
}

TEST_F(BagSourceTest, MonoColourIsExpandedToThreeChannels) {
  BagWriteOptions o;
  o.color_encoding = "mono8";
  auto source = testing::openOrFail("bag:" + writeBag(o), {});
  ASSERT_TRUE(source);
  const auto frames = testing::drainSource(*source);
  ASSERT_EQ(frames.size(), 20u);
  EXPECT_EQ(frames[0].color.type(), CV_8UC3);
}

TEST_F(BagSourceTest, MissingTopicsAreNamedWithWhatTheBagHas) {
  BagWriteOptions o;
  o.write_depth = false;
  o.write_info = false;
  const std::string bag = writeBag(o);
  const std::string e = openError("bag:" + bag);
  EXPECT_NE(e.find("no topic /camera/depth/image"), std::string::npos) << e;
  EXPECT_NE(e.find("/camera/rgb/image_color (sensor_msgs/Image)"), std::string::npos) << e;
  EXPECT_NE(e.find("?depth=TOPIC"), std::string::npos) << e;
  BagWriteOptions no_info;
  no_info.write_info = false;
  const std::string bag_without_info = writeBag(no_info, "no_info.bag");
  EXPECT_EQ(openError("bag:" + bag_without_info), "");  // the camera may come from elsewhere
  const std::string info =
      openError("bag:" + bag_without_info + "?info=/camera/rgb/camera_info");  // asked for
  EXPECT_NE(info.find("no topic /camera/rgb/camera_info"), std::string::npos) << info;
  const std::string wrong_type =
      openError("bag:" + writeBag({}, "full.bag") + "?depth=/camera/rgb/camera_info");
  EXPECT_NE(wrong_type.find("is sensor_msgs/CameraInfo, expected sensor_msgs/Image"), std::string::npos)
      << wrong_type;
}

TEST_F(BagSourceTest, UnsupportedEncodingIsAnErrorAtOpen) {
  BagWriteOptions o;
  o.depth_encoding = "8UC1";
  std::string e = openError("bag:" + writeBag(o));
  EXPECT_NE(e.find("unsupported depth encoding '8UC1'"), std::string::npos) << e;
  BagWriteOptions c;
  c.color_encoding = "yuv422";
  e = openError("bag:" + writeBag(c, "yuv.bag"));
  EXPECT_NE(e.find("unsupported colour encoding 'yuv422'"), std::string::npos) << e;
}

TEST_F(BagSourceTest, TruncatedAndForeignFilesFailWithAReason) {
  const std::string bag = writeBag({});
  const auto size = std::filesystem::file_size(bag);
  std::ifstream in(bag, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const double keep : {0.0, 0.001, 0.1, 0.5, 0.9, 0.999}) {
    const std::string cut = dir_.path("cut.bag");
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, static_cast<size_t>(keep * size));
    auto url = SourceUrl::parse("bag:" + cut);
    auto source = openFrameSource(*url, {});
    if (!source) {
      EXPECT_NE(source.error().find("bag " + cut), std::string::npos) << source.error();
      continue;
    }
    FrameRead r;  // opened (an index survived): reading on must end in a reason, never a crash
    while ((r = (*source)->next()).kind == FrameRead::Kind::kFrame) {
    }
    EXPECT_EQ(r.kind, FrameRead::Kind::kFailed) << "kept " << keep;
  }
  dir_.write("text.bag", "not a bag at all\n");
  EXPECT_NE(openError("bag:" + dir_.path("text.bag")).find("not a ROS 1 bag"), std::string::npos);
  EXPECT_NE(openError("bag:" + dir_.path("none.bag")).find("none.bag: no such file"), std::string::npos);
}

}  // namespace
}  // namespace rgbdmap
