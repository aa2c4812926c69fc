#pragma once
// A fresh temporary folder per test, removed when the test ends; or one per process and name, removed when the
// process exits.
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

namespace rgbdmap::testing {

class TempDir {
 public:
  TempDir() {
    static std::atomic<int> counter{0};
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::string name = info ? info->name() : "none";
    dir_ = std::filesystem::temp_directory_path() /
           ("rgbdmap_" + name + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string dir() const { return dir_.string(); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  void write(const std::string& name, const std::string& text) const { std::ofstream(dir_ / name) << text; }

 private:
  std::filesystem::path dir_;
};

/// The folders processDir() handed out, removed when the process exits unless RGBDMAP_KEEP_TEST_DIRS is set
/// (to look at a failed test's map directory).
class ProcessDirs {
 public:
  static void add(const std::string& dir) {
    static ProcessDirs dirs;
    const std::lock_guard<std::mutex> lock(dirs.mutex_);
    dirs.dirs_.push_back(dir);
  }
  ~ProcessDirs() {
    if (std::getenv("RGBDMAP_KEEP_TEST_DIRS")) return;
    std::error_code ec;
    for (const std::string& d : dirs_) std::filesystem::remove_all(d, ec);
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> dirs_;
};

/// `prefix` + `name` + the process id under the test temporary directory, not created; whatever is there is
/// removed now, and again when the process exits (ProcessDirs).
inline std::string processDir(const std::string& prefix, const std::string& name) {
  const std::string dir = ::testing::TempDir() + prefix + name + "_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  ProcessDirs::add(dir);
  return dir;
}

}  // namespace rgbdmap::testing
