// The shipped example configuration must load cleanly and state the real defaults.
#include <gtest/gtest.h>

#include "rgbdmap/client/odometry_config_io.hpp"

namespace rgbdmap {
namespace {

const std::string kExample = std::string(RGBDMAP_SOURCE_DIR) + "/deploy/config/odometry.yaml";

TEST(ConfigFiles, OdometryExampleLoadsWithoutErrors) {
  auto reader = ConfigReader::fromFile(kExample);
  ASSERT_TRUE(reader) << reader.error();
  CameraIntrinsics camera;
  OdometryConfig odometry;
  double max_time_diff = 0.02;
  readCameraConfig(*reader, "camera.", &camera);
  readOdometryConfig(*reader, &odometry);
  reader->read("dataset.max_time_diff", &max_time_diff, 0.0, 10.0);
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
