// The shipped server configuration loads cleanly, states the real defaults, and bad values are reported.
#include <fstream>

#include <gtest/gtest.h>

#include "common/temp_dir.hpp"
#include "config_file_check.hpp"
#include "rgbdmap/server/server_config.hpp"

namespace rgbdmap {
namespace {

const std::string kExample = std::string(RGBDMAP_SOURCE_DIR) + "/deploy/config/server.yaml";

TEST(ServerConfig, ExampleLoadsWithoutErrorsAndStatesTheDefaults) {
  auto reader = ConfigReader::fromFile(kExample);
  ASSERT_TRUE(reader) << reader.error();
  ServerAppConfig from_file;
  readServerConfig(*reader, &from_file);
  for (const auto& e : reader->errors()) ADD_FAILURE() << e;
  ConfigReader defaults;
  ServerAppConfig c;
  readServerConfig(defaults, &c);
  EXPECT_EQ(reader->effectiveValues(), defaults.effectiveValues());
  EXPECT_EQ(from_file.server.validate(), "");
}

TEST(ServerConfig, ExampleIsTheTablesRendering) {
  const char* header =
      "rgbdmap-server configuration: every key with its default value, [range] and meaning. Any key may be\n"
      "left out (the default applies); unknown keys and out-of-range values are reported together at\n"
      "start-up. Used by `rgbdmap-server --config FILE` and `rgbdmap run --server-config FILE`. Rendered "
      "from\n"
      "the config tables (serverConfigValues); tests/server/test_server_config.cpp checks that this file is\n"
      "exactly their rendering.";
  testing::expectFileEqualsRendering(kExample, renderConfigYaml(header, serverConfigValues({})));
}

TEST(ServerConfig, OccupancyRangesAreTheSameInTheFileAndInValidate) {
  // The voxel fraction and the sensor model: one range each, used by the reader and by validate().
  auto reader = ConfigReader::fromString("map:\n  cloud_voxel_fraction: 1.5\n  prob_hit: 0.5\n", "x.yaml");
  ASSERT_TRUE(reader);
  ServerAppConfig c;
  readServerConfig(*reader, &c);
  const auto errors = reader->errors();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("map.prob_hit = 0.5 is outside (0.5, 1)"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("map.cloud_voxel_fraction = 1.5 is outside [0, 1]"), std::string::npos)
      << errors[1];
  c.server.occupancy.cloud_voxel_fraction = 1.5;
  c.server.occupancy.prob_hit = 0.5;
  EXPECT_NE(c.server.validate().find("cloud_voxel_fraction = 1.5 is outside [0, 1]"), std::string::npos);
  EXPECT_NE(c.server.validate().find("prob_hit = 0.5 is outside (0.5, 1)"), std::string::npos);
}

TEST(ServerConfig, BadValuesAndUnknownKeysAreAllReported) {
  auto reader = ConfigReader::fromString(
      "server:\n  robots: \"robot0, bad id!\"\n  status_period_s: -1\nloop:\n  recent_k: 500\ngraph:\n  "
      "nope: 1\n",
      "x.yaml");
  ASSERT_TRUE(reader);
  ServerAppConfig c;
  readServerConfig(*reader, &c);
  EXPECT_EQ(reader->errors().size(), 3u) << "status_period_s, recent_k, unknown key";
  ASSERT_EQ(c.server.robots.size(), 2u);
  EXPECT_EQ(c.server.robots[0], "robot0");
  EXPECT_NE(c.server.validate().find("invalid robot id 'bad id!'"), std::string::npos);
}

TEST(ServerConfig, KeysFileIsParsedStrictly) {
  const std::string path = testing::processDir("rgbdmap_", "keys_test");
  {
    std::ofstream f(path);
    f << "# robots\nrobot0 " << std::string(64, 'a') << "\n\nrobot1 " << std::string(64, 'b')
      << "  # second\n";
  }
  auto keys = msg::readKeysFile(path);
  ASSERT_TRUE(keys) << keys.error();
  EXPECT_TRUE(keys->find("robot0"));
  EXPECT_TRUE(keys->find("robot1"));
  {
    std::ofstream f(path);
    f << "robot0 xyz\n";
  }
  auto bad = msg::readKeysFile(path);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find(":1:"), std::string::npos) << bad.error();
  EXPECT_FALSE(msg::readKeysFile(path + ".missing"));
}

}  // namespace
}  // namespace rgbdmap
