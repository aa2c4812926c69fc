// The programs' JSON layout and number printing (common/json_output) and the atomic text file writer.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <random>

#include "rgbdmap/common/json_output.hpp"
#include "rgbdmap/common/text_lines.hpp"
#include "temp_dir.hpp"

namespace rgbdmap {
namespace {

TEST(JsonOutput, LayoutKeepsPlainContainersOnOneLine) {
  Json j;
  j["mode"] = "slam";
  j["datasets"] = {"a\"b", "c"};
  j["server"] = {
      {"keyframes", 12}, {"rejected", {{"x", 1}, {"y", 2}}}, {"maps", Json::array({{"r0", "r1"}})}};
  j["robots"] = Json::array({{{"robot", "r0"}, {"merged", true}}});
  j["empty"] = Json::array();
  EXPECT_EQ(formatJson(j),
            "{\n"
            "  \"mode\": \"slam\",\n"
            "  \"datasets\": [\"a\\\"b\", \"c\"],\n"
            "  \"server\": {\n"
            "    \"keyframes\": 12,\n"
            "    \"rejected\": {\"x\": 1, \"y\": 2},\n"
            "    \"maps\": [[\"r0\", \"r1\"]]\n"
            "  },\n"
            "  \"robots\": [\n"
            "    {\"robot\": \"r0\", \"merged\": true}\n"
            "  ],\n"
            "  \"empty\": []\n"
            "}\n");
  EXPECT_EQ(compactJson(j["server"]),
            "{\"keyframes\":12,\"rejected\":{\"x\":1,\"y\":2},\"maps\":[[\"r0\",\"r1\"]]}");
}

TEST(JsonOutput, NumbersAsPrintfShowsThem) {
  // nlohmann's own dump() prints 0.23561 as 0.23561000000000001.
  EXPECT_EQ(
      compactJson(Json::array({jsonNumber(0.23561), jsonNumber(0.1), jsonNumber(1.0), jsonNumber(0.0)})),
      "[0.23561,0.1,1,0]");
  EXPECT_EQ(compactJson(jsonNumber(1234567.0)), "1.23457e+06");
  EXPECT_EQ(compactJson(jsonNumber(1234567.0, 9)), "1234567");
  EXPECT_EQ(compactJson(Json(60.0)), "60");
  EXPECT_EQ(compactJson(jsonNumber(0.0123456789, 9)), "0.0123456789");
  EXPECT_TRUE(jsonNumber(std::numeric_limits<double>::quiet_NaN()).is_null());
  EXPECT_TRUE(jsonNumber(std::numeric_limits<double>::infinity()).is_null());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> mantissa(0.5, 1.0);
  for (int i = 0; i < 20000; ++i) {
    const double v = std::ldexp(mantissa(rng), static_cast<int>(rng() % 60) - 30);
    for (const int digits : {6, 9}) {
      char expected[40];
      std::snprintf(expected, sizeof expected, "%.*g", digits, v);
      ASSERT_EQ(compactJson(jsonNumber(v, digits)), expected);
    }
  }
}

TEST(JsonOutput, InvalidUtf8IsReplacedNotThrown) {
  EXPECT_EQ(compactJson(Json("a\xff")), "\"a\xEF\xBF\xBD\"");
}

TEST(TextFileAtomic, ReplacesTheFileWhole) {
  testing::TempDir dir;
  const std::string path = dir.path("out.json");
  ASSERT_TRUE(writeTextFileAtomic(path, "old\n"));
  ASSERT_TRUE(writeTextFileAtomic(path, "new\n"));
  EXPECT_EQ(*readTextFile(path), "new\n");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.dir()), {}), 1);  // no temporary left
  EXPECT_FALSE(writeTextFileAtomic(dir.path("missing/out.json"), "x"));
}

}  // namespace
}  // namespace rgbdmap
