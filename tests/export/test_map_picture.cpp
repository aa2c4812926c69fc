// The top-down map picture: written as PNG, trajectories drawn in their colours, orientation, the ceiling
// cut, free / unknown colours, the octree left untouched, bad options and poses refused.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "common/temp_dir.hpp"
#include "rgbdmap/export/map_picture.hpp"

namespace rgbdmap {
namespace {

using testing::TempDir;

/// Map frame z up: a floor (z = -1.0), a 1 m wall block, a ceiling (z = 1.5) and free space between.
octomap::OcTree smallRoom(bool with_ceiling) {
  octomap::OcTree tree(0.1);
  auto at = [](int i) { return static_cast<float>(0.1 * i + 0.05); };  // voxel centres
  for (int ix = -20; ix < 20; ++ix)
    for (int iy = -10; iy < 30; ++iy) {
      tree.updateNode(octomap::point3d(at(ix), at(iy), at(-11)), true);
      if (with_ceiling) tree.updateNode(octomap::point3d(at(ix), at(iy), at(14)), true);
      tree.updateNode(octomap::point3d(at(ix), at(iy), at(-1)), false);
    }
  for (int ix = 5; ix < 15; ++ix)
    for (int iz = -10; iz < 10; ++iz) tree.updateNode(octomap::point3d(at(ix), at(25), at(iz)), true);
  return tree;
}

std::vector<SE3> straightPath(const Vec3& a, const Vec3& b, int n) {
  std::vector<SE3> poses;
  for (int i = 0; i < n; ++i) {
    SE3 T = SE3::Identity();
    T.translation() = a + (b - a) * (i / (n - 1.0));
    poses.push_back(T);
  }
  return poses;
}

bool near(const cv::Vec3b& px, const cv::Vec3b& want) {
  return std::abs(px[0] - want[0]) + std::abs(px[1] - want[1]) + std::abs(px[2] - want[2]) <= 3;
}

TEST(ExportPicture, WrittenWithTrajectoriesInTheirColoursAndTreeUntouched) {
  TempDir tmp;
  const octomap::OcTree tree = smallRoom(true);
  std::ostringstream before;
  tree.writeBinaryConst(before);
  const size_t nodes = tree.size();

  MapPictureOptions options;
  options.max_side_px = 400;
  const std::vector<NamedTrajectory> trajectories{
      {"alpha", straightPath(Vec3(-1.5, -0.5, 0), Vec3(-1.5, 2.0, 0), 30)},
      {"beta", straightPath(Vec3(-1.0, 0.0, 0), Vec3(1.5, 0.0, 0), 30)}};
  ASSERT_TRUE(writeMapPicture(tree, trajectories, tmp.path("map.png"), options));
  const cv::Mat png = cv::imread(tmp.path("map.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(png.empty());
  EXPECT_LE(std::max(png.cols, png.rows), 400);
  EXPECT_GE(std::max(png.cols, png.rows), 380);

  MapPictureLayout layout;
  auto rendered = renderMapPicture(tree, trajectories, options, &layout);
  ASSERT_TRUE(rendered) << rendered.error();
  EXPECT_EQ(cv::norm(*rendered, png, cv::NORM_INF), 0.0) << "the PNG is the rendered picture";
  for (size_t k = 0; k < trajectories.size(); ++k) {
    const auto& rgb = options.trajectory_rgb[k];
    const cv::Vec3b want(rgb[2], rgb[1], rgb[0]);
    for (int i : {5, 15, 25}) {  // along the polyline
      const cv::Point2d p = layout.toPixel(trajectories[k].second[i].translation());
      const cv::Vec3b got = png.at<cv::Vec3b>(static_cast<int>(p.y), static_cast<int>(p.x));
      EXPECT_TRUE(near(got, want)) << trajectories[k].first << " pose " << i << " pixel " << p << " = "
                                   << got;
    }
  }
  // Map y is up in the picture, x to the right (seen from above): the wall block (y = 2.55) is near the top.
  const cv::Point2d wall = layout.toPixel(Vec3(1.0, 2.55, 0.0));
  const cv::Point2d start = layout.toPixel(Vec3(1.0, 0.0, 0.0));
  EXPECT_LT(wall.y, start.y);
  EXPECT_GT(layout.toPixel(Vec3(1.5, 0, 0)).x, layout.toPixel(Vec3(-1.5, 0, 0)).x);
  // The ceiling is cut away: the wall's top is drawn in another colour than the floor around it, and the
  // picture has more than a handful of colours (a height colour map, grey, white, trajectories).
  const cv::Vec3b wall_px = png.at<cv::Vec3b>(static_cast<int>(wall.y), static_cast<int>(wall.x));
  const cv::Point2d floor_pt = layout.toPixel(Vec3(0.0, 1.5, 0.0));
  const cv::Vec3b floor_px = png.at<cv::Vec3b>(static_cast<int>(floor_pt.y), static_cast<int>(floor_pt.x));
  EXPECT_FALSE(near(wall_px, floor_px)) << wall_px << " vs " << floor_px;
  std::set<int> colours;
  for (int r = 0; r < png.rows; r += 3)
    for (int c = 0; c < png.cols; c += 3) {
      const cv::Vec3b v = png.at<cv::Vec3b>(r, c);
      colours.insert(v[0] << 16 | v[1] << 8 | v[2]);
    }
  EXPECT_GE(colours.size(), 6u);
  // Cutting the ceiling gives the picture of the room without one; drawing it hides everything under it.
  auto no_ceiling = renderMapPicture(smallRoom(false), trajectories, options);
  ASSERT_TRUE(no_ceiling) << no_ceiling.error();
  EXPECT_EQ(cv::norm(*no_ceiling, png, cv::NORM_INF), 0.0);
  MapPictureOptions keep_ceiling = options;
  keep_ceiling.ceiling_min_cover = 0.0;
  auto lid = renderMapPicture(tree, trajectories, keep_ceiling);
  ASSERT_TRUE(lid);
  EXPECT_TRUE(near(lid->at<cv::Vec3b>(static_cast<int>(wall.y), static_cast<int>(wall.x)),
                   lid->at<cv::Vec3b>(static_cast<int>(floor_pt.y), static_cast<int>(floor_pt.x))));

  std::ostringstream after;
  tree.writeBinaryConst(after);
  EXPECT_EQ(tree.size(), nodes);
  EXPECT_EQ(before.str(), after.str()) << "the picture must not change (prune) the tree";
}

TEST(ExportPicture, HasAHeightColourBarAndTheMapFramesAxes) {
  MapPictureOptions options;
  options.max_side_px = 400;
  const std::vector<NamedTrajectory> trajectories{{"alpha", straightPath(Vec3(-1, 0, 0), Vec3(1, 0, 0), 10)}};
  auto picture = renderMapPicture(smallRoom(false), trajectories, options);
  ASSERT_TRUE(picture) << picture.error();
  auto colours_in = [&](const cv::Rect& box) {
    std::set<int> colours;
    int black = 0;
    for (int r = box.y; r < box.y + box.height; ++r)
      for (int c = box.x; c < box.x + box.width; ++c) {
        const cv::Vec3b v = picture->at<cv::Vec3b>(r, c);
        colours.insert(v[0] << 16 | v[1] << 8 | v[2]);
        black += v[0] + v[1] + v[2] < 60;
      }
    return std::make_pair(colours.size(), black);
  };
  // Bottom right: the colour ramp from the lowest to the highest leaf, with its labels.
  const cv::Rect bar(picture->cols - 80, picture->rows - 140, 16, 120);
  EXPECT_GE(colours_in(bar).first, 30u);
  // Top right: the x and y arrows and the frame's name, in black.
  const auto [axes_colours, axes_black] = colours_in(cv::Rect(picture->cols - 100, 0, 100, 80));
  EXPECT_GE(axes_black, 100) << axes_colours << " colours";
}

TEST(ExportPicture, FreeSpaceGreyUnknownWhiteAndBadInputRejected) {
  octomap::OcTree tree(0.1);
  for (double x = 0.0; x < 1.0; x += 0.1) tree.updateNode(octomap::point3d(x, 0.05f, 0.05f), false);
  tree.updateNode(octomap::point3d(2.05f, 0.05f, 0.05f), true);
  MapPictureOptions options;
  options.max_side_px = 200;
  options.margin_px = 10;
  MapPictureLayout layout;
  auto image = renderMapPicture(tree, {}, options, &layout);
  ASSERT_TRUE(image) << image.error();
  const cv::Point2d free_pt = layout.toPixel(Vec3(0.45, 0.05, 0.05));
  EXPECT_EQ(image->at<cv::Vec3b>(static_cast<int>(free_pt.y), static_cast<int>(free_pt.x)),
            cv::Vec3b(225, 225, 225));
  const cv::Point2d unknown_pt = layout.toPixel(Vec3(1.5, 0.05, 0.05));
  EXPECT_EQ(image->at<cv::Vec3b>(static_cast<int>(unknown_pt.y), static_cast<int>(unknown_pt.x)),
            cv::Vec3b(255, 255, 255));

  EXPECT_FALSE(renderMapPicture(octomap::OcTree(0.1), {}, options)) << "nothing to draw";
  SE3 bad = SE3::Identity();
  bad.translation().x() = NAN;
  EXPECT_FALSE(renderMapPicture(tree, {{"r", {bad}}}, options));
  options.up_in_map = Vec3::Zero();
  options.max_side_px = 5;
  const std::string reasons = options.validate();
  EXPECT_NE(reasons.find("up_in_map"), std::string::npos) << reasons;
  EXPECT_NE(reasons.find("max_side_px"), std::string::npos) << reasons;
  EXPECT_FALSE(renderMapPicture(tree, {}, options));
  options = MapPictureOptions{};
  options.pixel_m = 1e-5;
  EXPECT_FALSE(renderMapPicture(tree, {}, options)) << "a picture over 10000 px is refused";
  EXPECT_FALSE(writeMapPicture(tree, {}, "/nonexistent_dir/map.png", MapPictureOptions{}));
}

}  // namespace
}  // namespace rgbdmap
