// Map exports: PLY (write/read, header, counts, truncation), voxel downsampling, ROS map_server slices (PGM +
// YAML round trip: values, origin, orientation), corrupted files. The picture: test_map_picture.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "common/temp_dir.hpp"
#include "rgbdmap/export/point_cloud_export.hpp"
#include "rgbdmap/export/slice_export.hpp"

namespace rgbdmap {
namespace {

using testing::TempDir;

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::vector<ColoredPoint> randomPoints(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  std::vector<ColoredPoint> points(n);
  for (size_t i = 0; i < n; ++i) {
    points[i].p = Eigen::Vector3f(u(rng), u(rng), u(rng));
    points[i].rgb = {static_cast<uint8_t>(rng()), static_cast<uint8_t>(rng()), static_cast<uint8_t>(rng())};
  }
  return points;
}

TEST(ExportPly, WriteReadKeepsCountsHeaderAndValues) {
  TempDir tmp;
  const auto points = randomPoints(1234, 1);
  ASSERT_TRUE(writePly(tmp.path("map.ply"), points));
  const std::string bytes = readBytes(tmp.path("map.ply"));
  const std::string header_end = "end_header\n";
  const size_t body = bytes.find(header_end) + header_end.size();
  const std::string header = bytes.substr(0, body);
  EXPECT_EQ(header.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u) << header;
  EXPECT_NE(header.find("\nelement vertex 1234\n"), std::string::npos) << header;
  EXPECT_NE(header.find("property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
                        "property uchar green\nproperty uchar blue\nend_header\n"),
            std::string::npos)
      << header;
  EXPECT_EQ(bytes.size(), body + 1234u * 15u);

  auto back = readPly(tmp.path("map.ply"));
  ASSERT_TRUE(back) << back.error();
  ASSERT_EQ(back->size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ((*back)[i].p, points[i].p) << i;
    EXPECT_EQ((*back)[i].rgb, points[i].rgb) << i;
  }
  ASSERT_TRUE(writePly(tmp.path("empty.ply"), {}));
  auto empty = readPly(tmp.path("empty.ply"));
  ASSERT_TRUE(empty) << empty.error();
  EXPECT_TRUE(empty->empty());
}

TEST(ExportPly, TruncatedOrMalformedFilesAreRejected) {
  TempDir tmp;
  ASSERT_TRUE(writePly(tmp.path("map.ply"), randomPoints(100, 2)));
  const std::string good = readBytes(tmp.path("map.ply"));
  const size_t body = good.find("end_header\n") + 11;

  writeBytes(tmp.path("cut.ply"), good.substr(0, good.size() - 7));
  auto cut = readPly(tmp.path("cut.ply"));
  ASSERT_FALSE(cut);
  EXPECT_NE(cut.error().find("truncated"), std::string::npos) << cut.error();

  writeBytes(tmp.path("long.ply"), good + "xx");
  EXPECT_FALSE(readPly(tmp.path("long.ply")));
  writeBytes(tmp.path("noend.ply"), good.substr(0, body - 11));
  EXPECT_FALSE(readPly(tmp.path("noend.ply")));

  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string h = good;
    h.replace(h.find(from), from.size(), to);
    return h;
  };
  for (const std::string& bad :
       {replaced("binary_little_endian", "binary_big_endian"), replaced("ply\n", "plx\n"),
        replaced("vertex 100", "vertex -1"), replaced("vertex 100", "vertex 99999999999"),
        replaced("property float z", "property double z"),
        replaced("element vertex 100", "element face 100")}) {
    writeBytes(tmp.path("bad.ply"), bad);
    EXPECT_FALSE(readPly(tmp.path("bad.ply"))) << bad.substr(0, body);
  }
  EXPECT_FALSE(readPly(tmp.path("missing.ply")));
}

TEST(ExportPly, NonFinitePointIsAnErrorAndNothingIsWritten) {
  TempDir tmp;
  auto points = randomPoints(10, 3);
  points[4].p.y() = std::nanf("");
  const Status s = writePly(tmp.path("nan.ply"), points);
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().find("point 4"), std::string::npos) << s.error();
  EXPECT_FALSE(std::filesystem::exists(tmp.path("nan.ply")));
  EXPECT_FALSE(writePly(tmp.path("no_such_dir/map.ply"), randomPoints(3, 4)));
}

TEST(ExportVoxelCloud, OnePointPerVoxelMeanPositionAndColourInMapFrame) {
  // 4000 points in a 1 m cube, 0.1 m voxels: at most 1000 voxels (1331 if the cube straddles boundaries),
  // every output point inside the cube, and in a different voxel.
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Eigen::Vector3f> points_cam;
  std::vector<std::array<uint8_t, 3>> rgb;
  for (int i = 0; i < 4000; ++i) {
    points_cam.emplace_back(u(rng), u(rng), u(rng));
    rgb.push_back({200, 100, 0});
  }
  SE3 T_map_cam = SE3::Identity();
  T_map_cam.linear() = Eigen::AngleAxisd(0.5, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  T_map_cam.translation() = Vec3(10.0, -3.0, 2.0);
  VoxelCloud cloud(0.1);
  ASSERT_TRUE(cloud.add(points_cam, rgb, T_map_cam));
  const size_t voxels = cloud.size();
  EXPECT_LE(voxels, 1331u);
  EXPECT_GE(voxels, 500u);
  // The same points again (another keyframe seeing the same surface) add no voxel: memory is bounded by
  // voxels.
  ASSERT_TRUE(cloud.add(points_cam, rgb, T_map_cam));
  EXPECT_EQ(cloud.size(), voxels);
  const auto out = cloud.points();
  ASSERT_EQ(out.size(), voxels);
  std::set<std::array<long, 3>> keys;
  for (const ColoredPoint& c : out) {
    const Vec3 p_cam = T_map_cam.inverse() * c.p.cast<double>();
    EXPECT_TRUE((p_cam.array() > -1e-4).all() && (p_cam.array() < 1.0 + 1e-4).all()) << p_cam.transpose();
    keys.insert({std::lround(std::floor(c.p.x() / 0.1)), std::lround(std::floor(c.p.y() / 0.1)),
                 std::lround(std::floor(c.p.z() / 0.1))});
    EXPECT_EQ(c.rgb, (std::array<uint8_t, 3>{200, 100, 0}));
  }
  EXPECT_EQ(keys.size(), out.size());

  // Two points in one voxel average; non-finite points are skipped and counted.
  VoxelCloud two(0.5);
  ASSERT_TRUE(two.add({{0.1f, 0.1f, 0.1f}, {0.3f, 0.2f, 0.1f}, {NAN, 0.f, 0.f}},
                      {{0, 0, 0}, {100, 51, 255}, {1, 1, 1}}, SE3::Identity()));
  ASSERT_EQ(two.size(), 1u);
  EXPECT_EQ(two.skipped(), 1u);
  const ColoredPoint mean = two.points()[0];
  EXPECT_NEAR(mean.p.x(), 0.2f, 1e-6f);
  EXPECT_NEAR(mean.p.y(), 0.15f, 1e-6f);
  EXPECT_EQ(mean.rgb, (std::array<uint8_t, 3>{50, 26, 128}));
}

TEST(ExportVoxelCloud, BadInputIsAnError) {
  VoxelCloud cloud(0.05);
  EXPECT_FALSE(cloud.add({{1, 2, 3}}, {}, SE3::Identity()));
  SE3 bad = SE3::Identity();
  bad.translation().x() = NAN;
  EXPECT_FALSE(cloud.add({{1, 2, 3}}, {{1, 2, 3}}, bad));
  EXPECT_EQ(cloud.size(), 0u);
  ASSERT_TRUE(cloud.add({{1e9f, 0, 0}}, {{1, 2, 3}}, SE3::Identity()));  // beyond +-2^20 voxels: skipped
  EXPECT_EQ(cloud.size(), 0u);
  EXPECT_EQ(cloud.skipped(), 1u);
  for (double v : {0.0, -1.0, std::nan("")})
    EXPECT_FALSE(VoxelCloud(v).add({{1, 2, 3}}, {{1, 2, 3}}, SE3::Identity())) << v;
}

/// A 7 x 5 slice with every kind of value, its grid turned by `yaw` about the z-up map's z and lifted by
/// `height_m`.
msg::OccupancySlice craftedSlice(double x, double y, double yaw, double height_m) {
  msg::OccupancySlice s;
  s.robot_id = "robot_7";
  s.header.utime = 1700000000123456;
  s.width = 7;
  s.height = 5;
  s.resolution_m = 0.1f;
  s.z_min_m = 0.2f;
  s.z_max_m = 1.5f;
  s.T_map_grid.linear() = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
  s.T_map_grid.translation() = Vec3(x, y, height_m);
  s.cells.assign(35, msg::OccupancySlice::kFree);
  s.cells[0] = msg::OccupancySlice::kOccupied;  // (col 0, row 0): the origin corner
  s.cells[6] = msg::OccupancySlice::kUnknown;   // (6, 0)
  s.cells[4 * 7 + 0] = 70;                      // (0, 4): above occupied_thresh -> occupied
  s.cells[4 * 7 + 6] = 30;                      // (6, 4): between the thresholds -> unknown
  s.cells[2 * 7 + 3] = 10;                      // (3, 2): below free_thresh -> free
  return s;
}

TEST(ExportSlice, PgmFollowsMapSaverAndRoundTrips) {
  TempDir tmp;
  const auto s = craftedSlice(1.5, -2.0, 0.7, 0.4);
  ASSERT_TRUE(writeSlice(s, tmp.path("slice_robot_7.pgm"), tmp.path("slice_robot_7.yaml")));

  // PGM bytes: P5, map_saver values, the image's top row is the grid's last row.
  const std::string pgm = readBytes(tmp.path("slice_robot_7.pgm"));
  ASSERT_EQ(pgm.substr(0, 3), "P5\n");
  const size_t pixels = pgm.size() - 35;
  EXPECT_NE(pgm.find("7 5\n255\n"), std::string::npos);
  auto pixel = [&](int col, int row) { return static_cast<uint8_t>(pgm[pixels + (4 - row) * 7 + col]); };
  EXPECT_EQ(pixel(0, 0), 0);
  EXPECT_EQ(pixel(6, 0), 205);
  EXPECT_EQ(pixel(0, 4), 0);
  EXPECT_EQ(pixel(6, 4), 205);
  EXPECT_EQ(pixel(3, 2), 254);
  EXPECT_EQ(pixel(1, 1), 254);
  EXPECT_EQ(static_cast<uint8_t>(pgm[pixels]), 0) << "top-left pixel = grid cell (0, 4)";

  // YAML: map_server's keys, origin in the (z-up) map frame.
  const YAML::Node y = YAML::LoadFile(tmp.path("slice_robot_7.yaml"));
  EXPECT_EQ(y["image"].as<std::string>(), "slice_robot_7.pgm");
  EXPECT_NEAR(y["resolution"].as<double>(), 0.1, 1e-7);
  const auto origin = y["origin"].as<std::vector<double>>();
  ASSERT_EQ(origin.size(), 3u);
  EXPECT_NEAR(origin[0], 1.5, 1e-6);
  EXPECT_NEAR(origin[1], -2.0, 1e-6);
  EXPECT_NEAR(origin[2], 0.7, 1e-6);
  EXPECT_EQ(y["negate"].as<int>(), 0);
  EXPECT_NEAR(y["occupied_thresh"].as<double>(), 0.65, 1e-9);
  EXPECT_NEAR(y["free_thresh"].as<double>(), 0.196, 1e-9);

  auto back = readSlice(tmp.path("slice_robot_7.yaml"));
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back->width, 7);
  EXPECT_EQ(back->height, 5);
  EXPECT_EQ(back->robot_id, "robot_7");
  EXPECT_EQ(back->header.utime, s.header.utime);
  EXPECT_FLOAT_EQ(back->resolution_m, 0.1f);
  EXPECT_FLOAT_EQ(back->z_min_m, 0.2f);
  EXPECT_TRUE(back->T_map_grid.isApprox(s.T_map_grid, 1e-6));
  for (size_t i = 0; i < s.cells.size(); ++i) {
    const int8_t want = s.cells[i] >= 65 ? 100 : (s.cells[i] >= 0 && s.cells[i] < 20 ? 0 : -1);
    EXPECT_EQ(back->cells[i], want) << "cell " << i;
  }
}

TEST(ExportSlice, PlainMapServerYamlReadsThroughOrigin) {
  TempDir tmp;
  const auto s = craftedSlice(-0.5, 3.0, -2.0, 0.0);
  ASSERT_TRUE(writeSlice(s, tmp.path("m.pgm"), tmp.path("m.yaml")));
  tmp.write("plain.yaml",
            "image: m.pgm\nresolution: 0.1\norigin: [-0.5, 3.0, -2.0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  auto back = readSlice(tmp.path("plain.yaml"));
  ASSERT_TRUE(back) << back.error();
  EXPECT_TRUE(back->T_map_grid.isApprox(s.T_map_grid, 1e-9));
  EXPECT_EQ(back->cells[0], 100);
  // Cell (col, row) centre = T_map_grid * ((col + 0.5) res, (row + 0.5) res, 0): the map's x axis turned by
  // yaw about z.
  const Vec3 c10 = back->T_map_grid * Vec3(0.15, 0.05, 0.0);
  const Vec3 c00 = back->T_map_grid * Vec3(0.05, 0.05, 0.0);
  EXPECT_NEAR((c10 - c00).x(), 0.1 * std::cos(-2.0), 1e-9);
  EXPECT_NEAR((c10 - c00).y(), 0.1 * std::sin(-2.0), 1e-9);
  EXPECT_NEAR((c10 - c00).z(), 0.0, 1e-12);
  tmp.write("negated.yaml", "image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 1\n");
  auto negated = readSlice(tmp.path("negated.yaml"));
  ASSERT_TRUE(negated) << negated.error();
  EXPECT_EQ(negated->cells[0], 0);
  EXPECT_EQ(negated->cells[1], 100);
}

TEST(ExportSlice, GlobalMapIsANav2MapWithoutYaw) {
  // A map's global 2-D map (map_<id>.pgm/.yaml): no robot, axis-aligned, at the robots' camera height.
  TempDir tmp;
  auto g = craftedSlice(-3.25, 1.75, 0.0, 0.45);
  g.robot_id.clear();
  ASSERT_TRUE(writeSlice(g, tmp.path("map_4.pgm"), tmp.path("map_4.yaml")));
  const std::string pgm = readBytes(tmp.path("map_4.pgm"));
  EXPECT_NE(pgm.find("# rgbdmap global occupancy map\n"), std::string::npos);
  const YAML::Node y = YAML::LoadFile(tmp.path("map_4.yaml"));
  for (const char* key : {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh"})
    EXPECT_TRUE(y[key]) << key << " (map_server needs it)";
  EXPECT_FALSE(y["robot_id"]);
  EXPECT_EQ(y["image"].as<std::string>(), "map_4.pgm");
  const auto origin = y["origin"].as<std::vector<double>>();
  ASSERT_EQ(origin.size(), 3u);
  EXPECT_EQ(origin[2], 0.0) << "nav2's static layer ignores yaw: there is none";
  EXPECT_EQ(readBytes(tmp.path("map_4.yaml")).find("-0]"), std::string::npos);
  EXPECT_NEAR(origin[0], -3.25, 1e-6);
  EXPECT_NEAR(origin[1], 1.75, 1e-6);
  EXPECT_EQ(y["negate"].as<int>(), 0);
  auto back = readSlice(tmp.path("map_4.yaml"));
  ASSERT_TRUE(back) << back.error();
  EXPECT_TRUE(back->robot_id.empty());
  EXPECT_TRUE(back->T_map_grid.isApprox(g.T_map_grid, 1e-6));
  EXPECT_NEAR(back->T_map_grid.translation().z(), 0.45, 1e-6);
  ASSERT_EQ(back->cells.size(), g.cells.size());
  for (size_t i = 0; i < g.cells.size(); ++i) {
    const int8_t want = g.cells[i] >= 65 ? 100 : (g.cells[i] >= 0 && g.cells[i] < 20 ? 0 : -1);
    EXPECT_EQ(back->cells[i], want) << "cell " << i;
  }
  // What map_server reads (origin only, the rgbdmap keys dropped): the same grid on the floor plane.
  tmp.write("plain.yaml",
            "image: map_4.pgm\nresolution: 0.1\norigin: [-3.25, 1.75, 0.0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  auto plain = readSlice(tmp.path("plain.yaml"));
  ASSERT_TRUE(plain) << plain.error();
  EXPECT_TRUE(plain->T_map_grid.linear().isApprox(Mat3::Identity(), 1e-12));
  EXPECT_EQ(plain->cells, back->cells);
}

TEST(ExportSlice, BadSlicesAndFilesAreErrors) {
  TempDir tmp;
  auto s = craftedSlice(0, 0, 0, 0);
  s.cells.pop_back();
  EXPECT_FALSE(writeSlice(s, tmp.path("a.pgm"), tmp.path("a.yaml")));
  s = craftedSlice(0, 0, 0, 0);
  s.cells[3] = 101;
  EXPECT_FALSE(writeSlice(s, tmp.path("a.pgm"), tmp.path("a.yaml")));
  s = craftedSlice(0, 0, 0, 0);
  s.resolution_m = NAN;
  EXPECT_FALSE(writeSlice(s, tmp.path("a.pgm"), tmp.path("a.yaml")));
  EXPECT_FALSE(std::filesystem::exists(tmp.path("a.pgm")));

  ASSERT_TRUE(writeSlice(craftedSlice(0, 0, 0, 0), tmp.path("b.pgm"), tmp.path("b.yaml")));
  const std::string pgm = readBytes(tmp.path("b.pgm"));
  writeBytes(tmp.path("b.pgm"), pgm.substr(0, pgm.size() - 1));
  auto truncated = readSlice(tmp.path("b.yaml"));
  ASSERT_FALSE(truncated);
  EXPECT_NE(truncated.error().find("pixel bytes"), std::string::npos) << truncated.error();
  writeBytes(tmp.path("b.pgm"), "P2" + pgm.substr(2));
  EXPECT_FALSE(readSlice(tmp.path("b.yaml")));
  writeBytes(tmp.path("b.pgm"), "P5\n7 5\n65535\n" + std::string(70, '\0'));
  EXPECT_FALSE(readSlice(tmp.path("b.yaml")));
  tmp.write("c.yaml", "image: b.pgm\nresolution: -1\norigin: [0, 0, 0]\n");
  EXPECT_FALSE(readSlice(tmp.path("c.yaml")));
  tmp.write("d.yaml", "image: b.pgm\nresolution: 0.1\norigin: [0, 0]\n");
  EXPECT_FALSE(readSlice(tmp.path("d.yaml")));
  tmp.write("e.yaml", "image: [b.pgm\n");
  EXPECT_FALSE(readSlice(tmp.path("e.yaml")));
  EXPECT_FALSE(readSlice(tmp.path("missing.yaml")));
}

TEST(ExportSlice, PgmInAnotherFolderIsNamedByAbsolutePath) {
  TempDir tmp;
  std::filesystem::create_directories(tmp.path("images"));
  const auto s = craftedSlice(0.5, 0.5, 0.3, 0.0);
  ASSERT_TRUE(writeSlice(s, tmp.path("images/r.pgm"), tmp.path("r.yaml")));
  const YAML::Node y = YAML::LoadFile(tmp.path("r.yaml"));
  EXPECT_TRUE(std::filesystem::path(y["image"].as<std::string>()).is_absolute());
  auto back = readSlice(tmp.path("r.yaml"));
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(back->cells[0], 100);
}

TEST(ExportFuzz, CorruptedFilesNeverCrashTheReaders) {
  TempDir tmp;
  ASSERT_TRUE(writePly(tmp.path("m.ply"), randomPoints(20, 9)));
  ASSERT_TRUE(writeSlice(craftedSlice(0, 0, 0, 0), tmp.path("s.pgm"), tmp.path("s.yaml")));
  const std::string ply = readBytes(tmp.path("m.ply")), pgm = readBytes(tmp.path("s.pgm"));
  const std::string yaml = readBytes(tmp.path("s.yaml"));
  std::mt19937 rng(11);
  int rejected = 0;
  for (int trial = 0; trial < 100; ++trial) {
    auto corrupt = [&](std::string bytes, size_t limit) {
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int f = 0; f < flips; ++f) bytes[rng() % std::min(limit, bytes.size())] = static_cast<char>(rng());
      if (rng() % 4 == 0) bytes.resize(rng() % bytes.size());
      return bytes;
    };
    writeBytes(tmp.path("c.ply"), corrupt(ply, 300));
    rejected += readPly(tmp.path("c.ply")).ok() ? 0 : 1;
    writeBytes(tmp.path("s.pgm"), corrupt(pgm, 60));
    writeBytes(tmp.path("c.yaml"), trial % 2 ? yaml : corrupt(yaml, yaml.size()));
    rejected += readSlice(tmp.path("c.yaml")).ok() ? 0 : 1;
  }
  EXPECT_GT(rejected, 40) << "most corruptions of headers are detected";
}

}  // namespace
}  // namespace rgbdmap
