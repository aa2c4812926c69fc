// The shipped example configuration must load cleanly and state the real defaults.
#include <gtest/gtest.h>

#include "config_file_check.hpp"
#include "rgbdmap/client/odometry_config_io.hpp"
#include "rgbdmap/vision/vision_config_tables.hpp"

namespace rgbdmap {
namespace {

const std::string kExample = std::string(RGBDMAP_SOURCE_DIR) + "/deploy/config/odometry.yaml";

TEST(ConfigFiles, OdometryExampleLoadsWithoutErrors) {
  auto reader = ConfigReader::fromFile(kExample);
  ASSERT_TRUE(reader) << reader.error();
  CameraIntrinsics camera;
  OdometryConfig odometry;
  DatasetOptions dataset;
  readCameraConfig(*reader, "camera.", &camera);
  readOdometryConfig(*reader, &odometry);
  readDatasetConfig(*reader, &dataset);
  const auto errors = reader->errors();
  for (const auto& e : errors) ADD_FAILURE() << e;
}

TEST(ConfigFiles, OdometryExampleStatesTheDefaults) {
  auto from_file = ConfigReader::fromFile(kExample);
  ASSERT_TRUE(from_file) << from_file.error();
  ConfigReader defaults;
  CameraIntrinsics c1, c2;
  OdometryConfig o1, o2;
  readCameraConfig(*from_file, "camera.", &c1);
  readOdometryConfig(*from_file, &o1);
  readCameraConfig(defaults, "camera.", &c2);
  readOdometryConfig(defaults, &o2);
  // The "key = value" listings of the values in effect must be identical line for line.
  EXPECT_EQ(from_file->effectiveValues(), defaults.effectiveValues());
}

const char* kOdometryHeader =
    "rgbdmap odometry configuration: every key with its default value, [range] and meaning. Any key may be\n"
    "left out (the default applies); unknown keys and out-of-range values are reported together at "
    "start-up.\n"
    "Used by `rgbdmap odometry|run --config FILE`. Rendered from the config tables (odometryFileValues);\n"
    "tests/client/test_config_files.cpp checks that this file is exactly their rendering.";

TEST(ConfigFiles, OdometryExampleIsTheTablesRendering) {
  testing::expectFileEqualsRendering(kExample,
                                     renderConfigYaml(kOdometryHeader, odometryFileValues({}, {}, {})));
}

TEST(ConfigFiles, ReaderAndValidationUseTheSameRange) {
  // ratio is in (0.1, 1]: the file reader and the table's check agree on every end.
  auto reader =
      ConfigReader::fromString("odometry:\n  matcher: {ratio: 0.05}\n  orb: {n_levels: 16}\n", "x.yaml");
  ASSERT_TRUE(reader);
  OdometryConfig o;
  readOdometryConfig(*reader, &o);
  ASSERT_EQ(reader->errors().size(), 1u);
  EXPECT_NE(reader->errors()[0].find("odometry.matcher.ratio = 0.05 is outside [0.1, 1]"), std::string::npos)
      << reader->errors()[0];
  EXPECT_EQ(o.orb.n_levels, 16);
  o.matcher.ratio = 0.05;
  const auto problems = odometryConfigTable().problems(o);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0], "matcher.ratio = 0.05 is outside [0.1, 1]");
}

TEST(ConfigFiles, OutOfRangeValuesAreAllReported) {
  auto reader = ConfigReader::fromString(
      "odometry:\n  orb:\n    n_features: 5\n    min_depth_m: 7\n  ransac:\n    confidence: 2\n  bogus: 1\n",
      "x.yaml");
  ASSERT_TRUE(reader);
  OdometryConfig o;
  readOdometryConfig(*reader, &o);
  const auto errors = reader->errors();
  EXPECT_EQ(errors.size(), 4u) << "n_features, min_depth vs max_depth, confidence, unknown key";
  EXPECT_EQ(o.orb.n_features, OdometryConfig{}.orb.n_features);
}

}  // namespace
}  // namespace rgbdmap
