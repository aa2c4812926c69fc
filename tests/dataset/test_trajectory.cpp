#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "common/file_size_limit.hpp"
#include "common/temp_dir.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "rgbdmap/dataset/trajectory.hpp"

namespace rgbdmap {
namespace {

size_t filesIn(const std::string& dir) {
  return static_cast<size_t>(std::distance(std::filesystem::directory_iterator(dir), {}));
}

TEST(Trajectory, ParseFormatRoundTrip) {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    Vec6 xi;
    xi << 0.1 * i, -0.2 * i, 0.3, 0.01 * i, 0.2, -0.1 * i;
    t.push_back({1305031229.528748 + 0.033 * i, se3::exp(xi)});
  }
  const auto parsed = parseTumTrajectory(formatTumTrajectory(t));
  ASSERT_TRUE(parsed) << parsed.error();
  ASSERT_EQ(parsed->size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR((*parsed)[i].timestamp, t[i].timestamp, 1e-6);
    EXPECT_LT(((*parsed)[i].T_world_cam.matrix() - t[i].T_world_cam.matrix()).norm(), 1e-6);
  }
}

TEST(Trajectory, SkipsCommentsAndBlankLines) {
  const auto r = parseTumTrajectory("# header\n\n  \n1.0 0 0 0 0 0 0 1\n# tail\n2.0 1 2 3 0 0 0 1\n");
  ASSERT_TRUE(r) << r.error();
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[1].T_world_cam.translation(), Vec3(1, 2, 3));
}

TEST(Trajectory, MalformedLinesNameTheLine) {
  struct Case {
    const char* text;
    const char* expect;
  };
  const Case cases[] = {
      {"1.0 0 0 0 0 0 0 1\n1.0 0 0 0 0 0 1\n", "x:2: expected 8 fields"},
      {"1.0 0 0 0 0 0 0 1 9\n", "x:1: expected 8 fields, got more"},
      {"1.0 0 zero 0 0 0 0 1\n", "x:1: 'zero' is not a number"},
      {"1.0 0 0 nan 0 0 0 1\n", "x:1: non-finite"},
      {"1.0 0 0 0 0 0 0 0\n", "x:1: zero quaternion"},
  };
  for (const auto& c : cases) {
    const auto r = parseTumTrajectory(c.text, "x");
    ASSERT_FALSE(r) << c.text;
    EXPECT_NE(r.error().find(c.expect), std::string::npos) << r.error();
  }
}

TEST(Trajectory, MissingFileIsAnError) {
  const auto r = readTumTrajectory("/nonexistent/traj.txt");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("cannot open"), std::string::npos);
}

TEST(Trajectory, WriterKeepsTheOldFileOnFailure) {
  testing::TempDir dir;
  const std::string path = dir.path("keyframes_robot0.txt");
  Trajectory small, large;
  small.push_back({1.0, SE3::Identity()});
  for (int i = 0; i < 2000; ++i) large.push_back({1.0 + i, SE3::Identity()});
  ASSERT_TRUE(writeTumTrajectory(path, small, "old"));
  const std::string old_text = *readTextFile(path);
  {
    testing::FileSizeLimit full(1024);
    ASSERT_TRUE(full.ok());
    EXPECT_FALSE(writeTumTrajectory(path, large, "new"));
  }
  EXPECT_EQ(*readTextFile(path), old_text);
  ASSERT_EQ(readTumTrajectory(path)->size(), 1u);
  EXPECT_EQ(filesIn(dir.dir()), 1u);
}

}  // namespace
}  // namespace rgbdmap
