// Data files found wherever the programs run from (common/data_files): RGBDMAP_DATA_DIR first, then
// share/rgbdmap beside the executable's folder, then the install prefix; a missing file names every place
// looked in.
#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "common/temp_dir.hpp"
#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/data_files.hpp"

namespace rgbdmap {
namespace {

class ScopedDataDir {
 public:
  explicit ScopedDataDir(const std::string& dir) { setenv("RGBDMAP_DATA_DIR", dir.c_str(), 1); }
  ~ScopedDataDir() { unsetenv("RGBDMAP_DATA_DIR"); }
};

TEST(DataFiles, TheEnvironmentFolderComesFirstThenTheExecutablesShareThenTheInstallPrefix) {
  testing::TempDir dir;
  ScopedDataDir env(dir.dir());
  const auto path = dataSearchPath("/opt/prefix/share/rgbdmap");
  ASSERT_EQ(path.size(), 3u);
  EXPECT_EQ(path[0], dir.dir());
  const std::string exe = std::filesystem::read_symlink("/proc/self/exe").parent_path().parent_path().string();
  EXPECT_EQ(path[1], exe + "/share/rgbdmap");
  EXPECT_EQ(path[2], "/opt/prefix/share/rgbdmap");
}

TEST(DataFiles, AFileInTheEnvironmentFolderIsFoundBeforeAnInstalledOne) {
  testing::TempDir env_dir, installed;
  std::filesystem::create_directories(env_dir.path("rgbdmap-test"));
  std::filesystem::create_directories(installed.path("rgbdmap-test"));
  ASSERT_TRUE(writeFileAtomic(env_dir.path("rgbdmap-test/index.html"), std::string("env")));
  ASSERT_TRUE(writeFileAtomic(installed.path("rgbdmap-test/index.html"), std::string("installed")));
  {
    ScopedDataDir env(env_dir.dir());
    const Result<std::string> found = findDataFile("rgbdmap-test/index.html", installed.dir());
    ASSERT_TRUE(found) << found.error();
    EXPECT_EQ(*found, env_dir.path("rgbdmap-test/index.html"));
  }
  const Result<std::string> found = findDataFile("rgbdmap-test/index.html", installed.dir());
  ASSERT_TRUE(found) << found.error();
  EXPECT_EQ(*found, installed.path("rgbdmap-test/index.html"));
}

TEST(DataFiles, AMissingFileNamesEveryPlaceLookedInAndTheSetting) {
  testing::TempDir env_dir, installed;
  ScopedDataDir env(env_dir.dir());
  const Result<std::string> found = findDataFile("dds/none.xml", installed.dir());
  ASSERT_FALSE(found);
  EXPECT_NE(found.error().find(env_dir.dir() + "/dds/none.xml"), std::string::npos) << found.error();
  EXPECT_NE(found.error().find(installed.dir() + "/dds/none.xml"), std::string::npos) << found.error();
  EXPECT_NE(found.error().find("RGBDMAP_DATA_DIR"), std::string::npos) << found.error();
}

TEST(DataFiles, AFolderOfTheSameNameIsNotAFile) {
  testing::TempDir installed;
  std::filesystem::create_directories(installed.path("rgbdmap-test/index.html"));
  EXPECT_FALSE(findDataFile("rgbdmap-test/index.html", installed.dir()));
}

}  // namespace
}  // namespace rgbdmap
