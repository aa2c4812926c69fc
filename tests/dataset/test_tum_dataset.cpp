#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "common/temp_dir.hpp"
#include "rgbdmap/dataset/tum_dataset.hpp"
#include "test_data.hpp"
#include "test_tier.hpp"

namespace rgbdmap {
namespace {
namespace fs = std::filesystem;

bool mentions(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

/// A tiny TUM-layout dataset in a fresh temporary folder, removed at the end of the test.
class TinyDataset : public testing::TempDir {
 public:
  TinyDataset() {
    fs::create_directories(path("rgb"));
    fs::create_directories(path("depth"));
  }
  void image(const std::string& name, const cv::Mat& m) const { ASSERT_TRUE(cv::imwrite(path(name), m)); }

  /// n frames of w x h, colour at t = i / 30, depth 5 ms later, plus matching list files.
  void standard(int n, int w = 8, int h = 6) const {
    std::string rgb = "# color images\n# timestamp filename\n", depth = "# depth maps\n";
    for (int i = 0; i < n; ++i) {
      const std::string tc = std::to_string(100.0 + i / 30.0), td = std::to_string(100.005 + i / 30.0);
      rgb += tc + " rgb/" + tc + ".png\n";
      depth += td + " depth/" + td + ".png\n";
      image("rgb/" + tc + ".png", cv::Mat(h, w, CV_8UC3, cv::Scalar(10 * i, 20, 30)));
      image("depth/" + td + ".png", cv::Mat(h, w, CV_16UC1, cv::Scalar(5000 + i)));
    }
    write("rgb.txt", rgb);
    write("depth.txt", depth);
  }
};

DatasetOptions tinyOptions() {
  DatasetOptions o;
  o.expected_width = 8;
  o.expected_height = 6;
  return o;
}

std::vector<ImageListEntry> list(const std::vector<double>& t) {
  std::vector<ImageListEntry> out;
  for (double v : t) out.push_back({v, std::to_string(v)});
  return out;
}

TEST(ImageAssociation, NearestWithinToleranceSortedByColourTime) {
  const auto f = associateImages(list({3.0, 1.0, 2.0}), list({2.5, 3.0078125, 1.0078125}), 0.02);
  ASSERT_EQ(f.size(), 2u);  // 2.0 has no depth within 0.02 s: dropped
  EXPECT_EQ(f[0].rgb_timestamp, 1.0);
  EXPECT_EQ(f[0].depth_timestamp, 1.0078125);
  EXPECT_EQ(f[1].rgb_timestamp, 3.0);
  EXPECT_EQ(f[1].depth_timestamp, 3.0078125);
}

TEST(ImageAssociation, GreedySmallestDifferenceEachUsedOnce) {
  // Depth 1.09375 is closest to colour 1.125 (0.03125) rather than 1.0 (0.09375): 1.0 loses it.
  const auto f = associateImages(list({1.0, 1.125}), list({1.09375}), 0.2);
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].rgb_timestamp, 1.125);
}

TEST(ImageAssociation, TiesGoToTheEarlierTimestamp) {
  auto f = associateImages(list({1.0}), list({1.25, 0.75}), 0.5);  // both 0.25 away
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].depth_timestamp, 0.75);
  f = associateImages(list({1.5, 1.0}), list({1.25}), 0.5);  // two colour frames 0.25 from one depth
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].rgb_timestamp, 1.0);
}

TEST(ImageAssociation, ToleranceIsStrict) {
  EXPECT_TRUE(associateImages(list({1.0}), list({1.5}), 0.5).empty());
  EXPECT_EQ(associateImages(list({1.0}), list({1.4375}), 0.5).size(), 1u);
}

TEST(ImageList, ParsesAndSkipsComments) {
  const auto r = parseImageList("# c\n\n 1.5 rgb/a.png\n2.25\trgb/b.png\r\n", "rgb.txt");
  ASSERT_TRUE(r) << r.error();
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[1].timestamp, 2.25);
  EXPECT_EQ((*r)[1].path, "rgb/b.png");
}

TEST(ImageList, MalformedLinesNameFileAndLine) {
  struct Case {
    const char* text;
    const char* expect;
  };
  const Case cases[] = {
      {"# h\n1.0 a.png\n2.0\n", "rgb.txt:3: expected 2 fields (timestamp filename), got 1"},
      {"1.0 a.png extra\n", "rgb.txt:1: expected 2 fields"},
      {"1.0 a.png\n1.x b.png\n", "rgb.txt:2: timestamp '1.x' is not a number"},
      {"inf a.png\n", "rgb.txt:1: timestamp is not finite"},
  };
  for (const auto& c : cases) {
    const auto r = parseImageList(c.text, "rgb.txt");
    ASSERT_FALSE(r) << c.text;
    EXPECT_TRUE(mentions(r.error(), c.expect)) << r.error();
  }
}

TEST(TumDataset, OpensAndLoadsTinyDataset) {
  TinyDataset d;
  d.standard(3);
  d.write("groundtruth.txt", "# gt\n100.0 1 2 3 0 0 0 1\n100.1 1 2 3 0 0 0 1\n");
  const auto ds = TumDataset::open(d.dir(), tinyOptions());
  ASSERT_TRUE(ds) << ds.error();
  ASSERT_EQ(ds->size(), 3u);
  EXPECT_EQ(ds->droppedRgbCount(), 0u);
  ASSERT_TRUE(ds->groundTruth().has_value());
  EXPECT_EQ(ds->groundTruth()->size(), 2u);
  const auto frame = ds->load(2);
  ASSERT_TRUE(frame) << frame.error();
  EXPECT_DOUBLE_EQ(frame->timestamp, ds->entry(2).rgb_timestamp);
  EXPECT_EQ(frame->color.type(), CV_8UC3);
  EXPECT_EQ(frame->depth.type(), CV_16UC1);
  EXPECT_EQ(frame->color.at<cv::Vec3b>(0, 0), cv::Vec3b(20, 20, 30));
  EXPECT_DOUBLE_EQ(frame->depthMetres(1, 1), 5002 / 5000.0);
  EXPECT_FALSE(ds->load(3));
}

TEST(TumDataset, GreyJpegColourAndPgmDepth) {
  TinyDataset d;
  d.write("rgb.txt", "1.0 rgb/a.png\n2.0 rgb/b.jpg\n");
  d.write("depth.txt", "1.0 depth/a.pgm\n2.0 depth/b.png\n");
  d.image("rgb/a.png", cv::Mat(6, 8, CV_8UC1, cv::Scalar(77)));
  d.image("rgb/b.jpg", cv::Mat(6, 8, CV_8UC3, cv::Scalar(50, 100, 150)));
  d.image("depth/a.pgm", cv::Mat(6, 8, CV_16UC1, cv::Scalar(40000)));
  d.image("depth/b.png", cv::Mat(6, 8, CV_16UC1, cv::Scalar(1000)));
  const auto ds = TumDataset::open(d.dir(), tinyOptions());
  ASSERT_TRUE(ds) << ds.error();
  const auto grey = ds->load(0);
  ASSERT_TRUE(grey) << grey.error();
  EXPECT_EQ(grey->color.type(), CV_8UC3);
  EXPECT_EQ(grey->color.at<cv::Vec3b>(3, 3), cv::Vec3b(77, 77, 77));
  EXPECT_EQ(grey->depth.at<uint16_t>(3, 3), 40000);  // 16-bit PGM keeps its full range
  const auto jpeg = ds->load(1);
  ASSERT_TRUE(jpeg) << jpeg.error();
  EXPECT_NEAR(jpeg->color.at<cv::Vec3b>(3, 3)[2], 150, 3);
}

TEST(TumDataset, DropsAndCountsColourWithoutDepth) {
  TinyDataset d;
  d.standard(3);
  d.write("rgb.txt", "100.0 rgb/100.000000.png\n100.5 rgb/x.png\n");  // 100.5: no depth within 0.02 s
  const auto ds = TumDataset::open(d.dir(), tinyOptions());
  ASSERT_TRUE(ds) << ds.error();
  EXPECT_EQ(ds->size(), 1u);
  EXPECT_EQ(ds->rgbCount(), 2u);
  EXPECT_EQ(ds->depthCount(), 3u);
  EXPECT_EQ(ds->droppedRgbCount(), 1u);
}

TEST(TumDataset, OpenErrorsNameTheFile) {
  EXPECT_TRUE(mentions(TumDataset::open("/nonexistent/ds").error(), "/nonexistent/ds: dataset folder"));
  TinyDataset d;
  EXPECT_TRUE(mentions(TumDataset::open(d.dir()).error(), "rgb.txt: cannot open"));
  d.write("rgb.txt", "1.0 rgb/a.png\n");
  EXPECT_TRUE(mentions(TumDataset::open(d.dir()).error(), "depth.txt: cannot open"));
  d.write("depth.txt", "# d\n1.0 depth/a.png 7\n");
  EXPECT_TRUE(mentions(TumDataset::open(d.dir()).error(), "depth.txt:2: expected 2 fields"));
  d.write("depth.txt", "5.0 depth/a.png\n");
  EXPECT_TRUE(mentions(TumDataset::open(d.dir()).error(), "no colour frame has a depth image within"));
  d.write("depth.txt", "1.0 depth/a.png\n");
  d.write("groundtruth.txt", "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 1\n");
  EXPECT_TRUE(mentions(TumDataset::open(d.dir()).error(), "groundtruth.txt:2: expected 8 fields"));
  DatasetOptions bad;
  bad.max_time_diff = -1;
  EXPECT_TRUE(mentions(TumDataset::open(d.dir(), bad).error(), "max_time_diff"));
}

TEST(TumDataset, LoadErrorsNameTheImage) {
  TinyDataset d;
  d.write("rgb.txt", "1.0 rgb/a.png\n2.0 rgb/b.png\n3.0 rgb/c.png\n4.0 rgb/d.png\n5.0 rgb/e.png\n");
  d.write("depth.txt",
          "1.0 depth/a.png\n2.0 depth/b.png\n3.0 depth/c.png\n4.0 depth/d.png\n5.0 depth/e.png\n");
  d.image("rgb/a.png", cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(1)));  // depth/a.png missing
  d.image("rgb/b.png", cv::Mat(5, 8, CV_8UC3, cv::Scalar::all(1)));  // wrong size
  d.image("depth/b.png", cv::Mat(6, 8, CV_16UC1, cv::Scalar::all(1)));
  d.image("rgb/c.png", cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(1)));
  d.image("depth/c.png", cv::Mat(6, 8, CV_8UC1, cv::Scalar::all(1)));  // 8-bit depth
  d.image("rgb/d.png", cv::Mat(6, 8, CV_8UC3, cv::Scalar::all(1)));
  d.image("depth/d.png", cv::Mat(4, 4, CV_16UC1, cv::Scalar::all(1)));  // size differs from colour
  d.write("rgb/e.png", "not a png");
  d.image("depth/e.png", cv::Mat(6, 8, CV_16UC1, cv::Scalar::all(1)));
  DatasetOptions any_size;
  any_size.expected_width = any_size.expected_height = 0;
  const auto strict = TumDataset::open(d.dir(), tinyOptions());
  const auto loose = TumDataset::open(d.dir(), any_size);
  ASSERT_TRUE(strict && loose);
  EXPECT_TRUE(mentions(strict->load(0).error(), "depth/a.png: depth image not found"))
      << strict->load(0).error();
  EXPECT_TRUE(mentions(strict->load(1).error(), "rgb/b.png: image is 8x5, expected 8x6"))
      << strict->load(1).error();
  EXPECT_TRUE(mentions(strict->load(2).error(), "depth/c.png: depth image has type CV_8UC1"));
  EXPECT_TRUE(mentions(strict->load(3).error(), "depth/d.png: image is 4x4"));
  EXPECT_TRUE(mentions(loose->load(3).error(), "colour rgb/d.png is 8x6 but depth depth/d.png is 4x4"))
      << loose->load(3).error();
  EXPECT_TRUE(mentions(strict->load(4).error(), "rgb/e.png: cannot read colour image"));
}

RGBDMAP_TEST_TIER("TumDatasetReal.*", "e2e sanitize");
TEST(TumDatasetReal, Fr1RpyFirst250) {
  RGBDMAP_REQUIRE_SHARED_DATA("tum_fr1_rpy_first250");
  const auto ds = TumDataset::open(testing::sharedDataDir("tum_fr1_rpy_first250"));
  ASSERT_TRUE(ds) << ds.error();
  EXPECT_EQ(ds->rgbCount(), 250u);
  EXPECT_EQ(ds->depthCount(), 251u);
  EXPECT_EQ(ds->size(), 250u);  // every colour frame has depth within 0.02 s (largest gap 14 ms)
  ASSERT_TRUE(ds->groundTruth().has_value());
  EXPECT_GT(ds->groundTruth()->size(), 1000u);
  for (size_t i = 0; i + 1 < ds->size(); ++i) {
    ASSERT_LT(ds->entry(i).rgb_timestamp, ds->entry(i + 1).rgb_timestamp);
    ASSERT_LT(std::abs(ds->entry(i).rgb_timestamp - ds->entry(i).depth_timestamp), 0.02);
  }
  for (size_t i : {size_t{0}, size_t{125}, size_t{249}}) {
    const auto frame = ds->load(i);
    ASSERT_TRUE(frame) << frame.error();
    std::vector<double> depths;
    for (int y = 0; y < frame->depth.rows; y += 4)
      for (int x = 0; x < frame->depth.cols; x += 4)
        if (frame->depthMetres(x, y) > 0) depths.push_back(frame->depthMetres(x, y));
    EXPECT_GT(depths.size(), 0.5 * (640 / 4) * (480 / 4)) << "frame " << i;
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    const double median = depths[depths.size() / 2];
    EXPECT_GT(median, 0.5);  // an office scene seen by a Kinect
    EXPECT_LT(median, 4.0);
    EXPECT_LT(*std::max_element(depths.begin(), depths.end()), 10.0);
  }
}

TEST(TumDatasetReal, Fr1Desk9Frames) {
  RGBDMAP_REQUIRE_SHARED_DATA("tum_fr1_desk_9frames");
  const auto ds = TumDataset::open(testing::sharedDataDir("tum_fr1_desk_9frames"));
  ASSERT_TRUE(ds) << ds.error();
  EXPECT_EQ(ds->size(), 9u);
  ASSERT_TRUE(ds->groundTruth().has_value());
  for (size_t i = 0; i < ds->size(); ++i) {
    const auto frame = ds->load(i);
    ASSERT_TRUE(frame) << frame.error();
    EXPECT_EQ(frame->color.size(), cv::Size(640, 480));
  }
  const auto camera = readDatasetCamera(ds->dir());
  ASSERT_TRUE(camera) << camera.error();
  EXPECT_FALSE(camera->has_value());  // TUM ships no camera.yaml
}

}  // namespace
}  // namespace rgbdmap
