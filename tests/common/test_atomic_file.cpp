// Files written whole or not at all (common/atomic_file): the old file survives a failed write, no
// temporary file is left behind, and the writers built on it (text, TUM trajectories) behave the same.
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "common/file_size_limit.hpp"
#include "common/temp_dir.hpp"
#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/common/text_lines.hpp"

namespace rgbdmap {
namespace {

size_t filesIn(const std::string& dir) {
  return static_cast<size_t>(std::distance(std::filesystem::directory_iterator(dir), {}));
}

TEST(AtomicFile, ReplacesTheFileWholeAndLeavesNoTemporary) {
  testing::TempDir dir;
  const std::string path = dir.path("map.bt");
  ASSERT_TRUE(writeFileAtomic(path, std::string("old")));
  const std::string binary("\0\x01\xff new", 7);
  ASSERT_TRUE(writeFileAtomic(path, binary));
  EXPECT_EQ(*readTextFile(path), binary);
  EXPECT_EQ(filesIn(dir.dir()), 1u);
  ASSERT_TRUE(writeFileAtomic(path, "", AtomicWriteOptions{false}));  // unsynced: still whole
  EXPECT_EQ(std::filesystem::file_size(path), 0u);
}

TEST(AtomicFile, FailedWriteKeepsTheOldFile) {
  testing::TempDir dir;
  const std::string path = dir.path("server_summary.json");
  const std::string old_text = "{\"keyframes\": 12}\n";
  ASSERT_TRUE(writeFileAtomic(path, old_text));
  Status failed = Status::success();
  {
    testing::FileSizeLimit full(4096);  // a disk with 4 KB left
    ASSERT_TRUE(full.ok());
    failed = writeFileAtomic(path, std::string(64 * 1024, 'x'));
  }
  ASSERT_FALSE(failed);
  EXPECT_NE(failed.error().find("write failed"), std::string::npos) << failed.error();
  EXPECT_EQ(*readTextFile(path), old_text);                         // the good file is still there, whole
  EXPECT_EQ(filesIn(dir.dir()), 1u);                                // and the partial temporary is gone
  ASSERT_TRUE(writeFileAtomic(path, std::string(64 * 1024, 'x')));  // space again: it works
  EXPECT_EQ(std::filesystem::file_size(path), 64u * 1024u);
}

TEST(AtomicFile, MissingFolderOrEmptyNameIsAnError) {
  testing::TempDir dir;
  const Status s = writeFileAtomic(dir.path("missing/out.txt"), "x");
  ASSERT_FALSE(s);
  EXPECT_NE(s.error().find("missing/out.txt"), std::string::npos) << s.error();
  EXPECT_FALSE(writeFileAtomic("", "x"));
}

TEST(AtomicFile, ConcurrentWritersOfOneFileLeaveOneWholeVersion) {
  testing::TempDir dir;
  const std::string path = dir.path("keyframes_robot0.txt");
  std::vector<std::thread> writers;
  for (int t = 0; t < 4; ++t)
    writers.emplace_back([&, t] {
      for (int i = 0; i < 20; ++i)
        ASSERT_TRUE(writeFileAtomic(path, std::string(1000 + t, static_cast<char>('a' + t))));
    });
  for (std::thread& w : writers) w.join();
  const std::string text = *readTextFile(path);
  ASSERT_GE(text.size(), 1000u);
  EXPECT_EQ(text, std::string(text.size(), text[0]));  // one writer's version, not a mix
  EXPECT_EQ(filesIn(dir.dir()), 1u);
}

TEST(AtomicFile, FolderOf) {
  EXPECT_EQ(folderOf("a/b/c.txt"), "a/b");
  EXPECT_EQ(folderOf("c.txt"), ".");
  EXPECT_EQ(folderOf("/c"), "/");
  EXPECT_TRUE(syncFolder("."));
  EXPECT_FALSE(syncFolder("/nonexistent-rgbdmap-folder"));
}

}  // namespace
}  // namespace rgbdmap
