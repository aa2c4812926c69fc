#pragma once
// The documented configuration files (deploy/config/*.yaml) are the config tables rendered with the
// defaults: a key, default, range or meaning changed on one side only fails here. On a mismatch the
// rendering is written to the test's temporary folder, ready to copy over the file.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace rgbdmap::testing {

inline void expectFileEqualsRendering(const std::string& path, const std::string& rendered) {
  std::ifstream in(path);
  ASSERT_TRUE(in) << "cannot read " << path;
  std::stringstream file;
  file << in.rdbuf();
  if (file.str() == rendered) return;
  const std::string out = ::testing::TempDir() + std::filesystem::path(path).filename().string();
  std::ofstream(out) << rendered;
  ADD_FAILURE() << path << " differs from the config tables' rendering; the rendering is in " << out
                << " (cp it over the file if the tables are right):\n"
                << rendered;
}

}  // namespace rgbdmap::testing
