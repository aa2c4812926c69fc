// The shipped server configuration loads cleanly, states the real defaults, and bad values are reported.
#include <fstream>

#include <gtest/gtest.h>

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
  const std::string path = ::testing::TempDir() + "rgbdmap_keys_test.txt";
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
