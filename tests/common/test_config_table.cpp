// Config tables: one range per value used for reading, checking, documenting and logging.
#include <gtest/gtest.h>

#include "rgbdmap/common/config_table.hpp"
#include "rgbdmap/common/logging.hpp"

namespace rgbdmap {
namespace {

enum class Mode { kFast, kSlow };

struct Inner {
  double ratio = 0.5;
  Mode mode = Mode::kFast;
};

struct Outer {
  int count = 3;
  float scale = 1.2f;
  std::string name = "a";
  bool flag = true;
  Inner inner;
  double hidden = 1.0;
};

const ConfigTable<Inner>& innerTable() {
  static const ConfigTable<Inner> t =
      ConfigTable<Inner>()
          .add("ratio", &Inner::ratio, ConfigRange::openClosed(0.0, 1.0), "share of it")
          .addChoice("mode", &Inner::mode, {{Mode::kFast, "fast"}, {Mode::kSlow, "slow"}}, "");
  return t;
}

const ConfigTable<Outer>& outerTable() {
  static const ConfigTable<Outer> t =
      ConfigTable<Outer>()
          .add("count", &Outer::count, ConfigRange::closed(1, 10), "how many\nsecond line")
          .add("scale", &Outer::scale, ConfigRange::closed(1.2, 2.0), "")
          .add("name", &Outer::name, "", {"a", "b"})
          .add("flag", &Outer::flag, "on or off")
          .section("inner", "the inner part")
          .nest("inner.", &Outer::inner, innerTable())
          .add("hidden", &Outer::hidden, ConfigRange::above(0.0), "")
          .codeOnly();
  return t;
}

TEST(ConfigRange, OpenAndClosedEnds) {
  EXPECT_EQ(ConfigRange::closed(0, 1).str(), "[0, 1]");
  EXPECT_EQ(ConfigRange::openClosed(0.5, 1).str(), "(0.5, 1]");
  EXPECT_EQ(ConfigRange::atLeast(0).str(), "[0, inf)");
  EXPECT_TRUE(ConfigRange::closed(0, 1).contains(0.0));
  EXPECT_FALSE(ConfigRange::open(0, 1).contains(0.0));
  EXPECT_FALSE(ConfigRange::open(0, 1).contains(1.0));
  EXPECT_TRUE(ConfigRange::open(0, 1).contains(0.5));
  EXPECT_FALSE(ConfigRange::any().contains(std::nan("")));
  EXPECT_FALSE(ConfigRange::atLeast(0).contains(std::numeric_limits<double>::infinity()));
  EXPECT_TRUE(ConfigRange::closed(1.01, 2.0).contains(1.01f)) << "float ends are rounded like the value";
  EXPECT_TRUE(ConfigRange::closed(0, 4294967295.0).contains(4294967295u));
}

TEST(ConfigTable, ReadsChecksDocumentsAndLogsFromOneTable) {
  auto reader = ConfigReader::fromString(
      "count: 11\nscale: 1.5\nname: c\ninner: {ratio: 0, mode: slow}\nhidden: 2\n", "t.yaml");
  ASSERT_TRUE(reader);
  Outer o;
  outerTable().read(*reader, &o);
  const auto errors = reader->errors();
  ASSERT_EQ(errors.size(), 4u);
  EXPECT_EQ(errors[0], "t.yaml: count = 11 is outside [1, 10]");
  EXPECT_EQ(errors[1], "t.yaml: name: 'c' is not one of a|b");
  EXPECT_EQ(errors[2], "t.yaml: inner.ratio = 0 is outside (0, 1]");
  EXPECT_EQ(errors[3], "t.yaml: unknown key 'hidden'") << "code-only fields are not read";
  EXPECT_FLOAT_EQ(o.scale, 1.5f);
  EXPECT_EQ(o.inner.mode, Mode::kSlow);

  Outer bad;
  bad.count = 0;
  bad.inner.ratio = 2;
  bad.hidden = -1;
  bad.name = "z";
  const auto problems = outerTable().problems(bad);
  ASSERT_EQ(problems.size(), 4u);
  EXPECT_EQ(problems[0], "count = 0 is outside [1, 10]");
  EXPECT_EQ(problems[1], "name = z is not one of a | b");
  EXPECT_EQ(problems[2], "inner.ratio = 2 is outside (0, 1]");
  EXPECT_EQ(problems[3], "hidden = -1 is outside (0, inf)");
  EXPECT_TRUE(outerTable().problems(Outer{}).empty());

  const std::vector<ConfigValue> values = outerTable().values(Outer{}, "top.");
  EXPECT_EQ(renderConfigYaml("Example.", values),
            "# Example.\n"
            "\n"
            "top:\n"
            "  count: 3                # [1, 10] how many\n"
            "                          # second line\n"
            "  scale: 1.2              # [1.2, 2]\n"
            "  name: \"a\"               # a | b\n"
            "  flag: true              # on or off\n"
            "  inner:                  # the inner part\n"
            "    ratio: 0.5            # (0, 1] share of it\n"
            "    mode: fast            # fast | slow\n");
  EXPECT_EQ(formatConfigValues(values),
            "  top: count = 3, scale = 1.2, name = \"a\", flag = true\n"
            "  top.inner: ratio = 0.5, mode = fast\n");
  // The rendering reads back to the same values without errors.
  auto back = ConfigReader::fromString(renderConfigYaml("x", outerTable().values(Outer{})), "r.yaml");
  ASSERT_TRUE(back) << back.error();
  Outer again;
  outerTable().read(*back, &again);
  EXPECT_TRUE(back->errors().empty());
}

TEST(ConfigTable, LogsOneInfoLineOfWhatDiffersFromTheDefaultsAndEveryValueAtDebug) {
  std::vector<std::pair<log::Level, std::string>> lines;
  const log::Level old_level = log::level();
  log::setLevel(log::Level::kDebug);
  log::setSink([&](log::Level l, const std::string& m) { lines.emplace_back(l, m); });
  Outer changed;
  changed.count = 5;
  changed.inner.mode = Mode::kSlow;
  logConfiguration("configuration in effect", outerTable().values(changed), outerTable().values(Outer()));
  logConfiguration("configuration in effect", outerTable().values(Outer()), outerTable().values(Outer()));
  log::setSink(nullptr);
  log::setLevel(old_level);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0].first, log::Level::kInfo);
  EXPECT_NE(lines[0].second.find("6 settings, 2 not at their defaults: count = 5, inner.mode = slow"),
            std::string::npos)
      << lines[0].second;
  EXPECT_EQ(lines[1].first, log::Level::kDebug);
  EXPECT_NE(lines[1].second.find("count = 5, scale = 1.2"), std::string::npos) << lines[1].second;
  EXPECT_NE(lines[2].second.find("6 settings, all at their defaults"), std::string::npos) << lines[2].second;
}

}  // namespace
}  // namespace rgbdmap
