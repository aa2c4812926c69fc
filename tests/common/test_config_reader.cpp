#include <gtest/gtest.h>

#include "rgbdmap/common/config_reader.hpp"

namespace rgbdmap {
namespace {

TEST(ConfigReader, ReadsValuesAndKeepsDefaults) {
  auto r =
      ConfigReader::fromString("odometry:\n  orb:\n    n_features: 1500\n  ratio: 0.8\nname: lcm\n", "cfg");
  ASSERT_TRUE(r) << r.error();
  int n = 1000, gap = 30;
  double ratio = 0.9;
  std::string name = "memq";
  r->read("odometry.orb.n_features", &n, 10, 10000);
  r->read("odometry.max_frame_gap", &gap, 1, 1000);
  r->read("odometry.ratio", &ratio, 0.0, 1.0);
  r->read("name", &name, {"memq", "lcm", "dds"});
  EXPECT_EQ(n, 1500);
  EXPECT_EQ(gap, 30);
  EXPECT_DOUBLE_EQ(ratio, 0.8);
  EXPECT_EQ(name, "lcm");
  EXPECT_TRUE(r->errors().empty());
  EXPECT_NE(r->effectiveValues().find("odometry.max_frame_gap = 30"), std::string::npos);
}

TEST(ConfigReader, ReportsAllErrorsTogether) {
  auto r = ConfigReader::fromString("a: -5\nb: abc\nc: [1, 2]\nd: udp\ntypo: 1\nx: .nan\n", "cfg.yaml");
  ASSERT_TRUE(r);
  int a = 1;
  double b = 0, x = 1;
  double c[3] = {0, 0, 0};
  std::string d = "memq";
  r->read("a", &a, 0, 10);
  r->read("b", &b, 0.0, 1.0);
  r->readList("c", c, 3);
  r->read("d", &d, {"memq", "lcm"});
  r->read("x", &x, 0.0, 10.0);
  const auto errors = r->errors();
  ASSERT_EQ(errors.size(), 6u);
  EXPECT_NE(errors[0].find("a = -5 is outside [0, 10]"), std::string::npos);
  EXPECT_NE(errors[1].find("'abc' is not a valid number"), std::string::npos);
  EXPECT_NE(errors[2].find("list of 3"), std::string::npos);
  EXPECT_NE(errors[3].find("not one of memq|lcm"), std::string::npos);
  EXPECT_NE(errors[4].find("x"), std::string::npos);
  EXPECT_NE(errors[5].find("unknown key 'typo'"), std::string::npos);
  EXPECT_EQ(a, 1) << "a rejected value must not replace the default";
}

TEST(ConfigReader, BadSyntaxAndMissingFile) {
  EXPECT_FALSE(ConfigReader::fromString("a: [1, 2", "bad"));
  EXPECT_FALSE(ConfigReader::fromString("- 1\n- 2\n", "list"));
  const auto missing = ConfigReader::fromFile("/nonexistent/config.yaml");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().find("cannot open"), std::string::npos);
}

TEST(ConfigReader, EmptyConfigKeepsEverything) {
  ConfigReader r;
  int n = 7;
  r.read("a.b", &n, 0, 10);
  EXPECT_EQ(n, 7);
  EXPECT_TRUE(r.errors().empty());
}

}  // namespace
}  // namespace rgbdmap
